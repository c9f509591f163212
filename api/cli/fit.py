"""``rcb fit``: fit a power-law model with its band to test data in a CSV file.

The command reads the CSV with pandas, keeps the rows that match every ``--where``, checks
every value it uses (rows are counted from 1 after the header line), and fits
``Y = K · Π x_i^e_i`` with :func:`models.fit.fit_power_law`. ``--write-tool`` writes the model
as one ``[[tools]]`` entry of a plan file (TOML) that :func:`models.tool.tool_from_mapping`
reads back; the file is written atomically and only when everything succeeded.

Errors follow ``rcb`` (exit 2, one line ``rcb: error: FIELD = VALUE: reason``;
:func:`api.cli.common.errors`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

from api.cli.common import JsonOption, emit, errors, say
from api.cli.tables import new_table
from models.errors import InputError
from models.quantities import MODEL_QUANTITIES

if TYPE_CHECKING:
    from models.fit import FitResult
    from models.fit_band import Band

_out = Console()


def fit(
    data: Annotated[
        Path, typer.Argument(metavar="DATA.csv", help="Test data: a CSV file with a header line.")
    ],
    response: Annotated[
        str,
        typer.Option(
            "--response",
            help="Column of the measured quantity Y (with --life-to-wear: of the time).",
        ),
    ],
    var: Annotated[
        list[str] | None,
        typer.Option(
            "--var",
            help="NAME=COLUMN: a model variable (a parameter or context of --process) and its "
            "column, or COLUMN/NUMBER for the column divided by a number, e.g. "
            "feed_per_tooth_mm=feed/6 (repeatable).",
        ),
    ] = None,
    fix: Annotated[
        list[str] | None,
        typer.Option("--fix", help="NAME=EXPONENT: an exponent not to fit (repeatable)."),
    ] = None,
    band: Annotated[
        str,
        typer.Option(
            "--band", help="range: ΔK holds every point (Ivester & Heigel); 2s: ΔK = K(e^(k·s)−1)."
        ),
    ] = "range",
    k: Annotated[
        float | None,
        typer.Option("--k", help="Coverage factor of --band 2s (default 2, NIST TN 1297)."),
    ] = None,
    where: Annotated[
        list[str] | None,
        typer.Option(
            "--where",
            help="COLUMN=TEXT: keep the rows whose cell is this text (repeatable; all must hold).",
        ),
    ] = None,
    quantity: Annotated[
        str | None,
        typer.Option("--quantity", help="What Y is: force_N, roughness_um, tool_life_mm3 ..."),
    ] = None,
    process: Annotated[
        str, typer.Option("--process", help="turning or milling: which variable names exist.")
    ] = "turning",
    tool_name: Annotated[
        str | None, typer.Option("--tool-name", help="Name of the tool --write-tool writes.")
    ] = None,
    write_tool: Annotated[
        Path | None,
        typer.Option("--write-tool", help="Write the model here as a plan-file tool (TOML)."),
    ] = None,
    life_to_wear: Annotated[
        float | None,
        typer.Option(
            "--life-to-wear",
            metavar="VB_MM",
            help="Fit tool life: per tool (--series) the --response time at which its flank "
            "wear (--wear) first reaches VB_MM [mm], e.g. 0.3 (ISO 3685).",
        ),
    ] = None,
    wear: Annotated[
        str | None,
        typer.Option("--wear", help="Column of the flank wear [mm] (default VB)."),
    ] = None,
    series: Annotated[
        str | None,
        typer.Option("--series", help="Column naming each tool's rows (default case)."),
    ] = None,
    as_json: JsonOption = False,
) -> None:
    """Fit Y = K·Π x^e by least squares on logarithms, with a band ±ΔK, from a CSV file.

    Rows in error messages are counted from 1 after the header line (blank lines skipped).
    """
    # imported here (pandas, NumPy): rcb --help and the other commands do not load them
    from api.cli.fit_checks import fit_warnings
    from api.cli.fit_data import (
        check_column,
        positive_numbers,
        read_csv,
        select_rows,
        wear_lives,
        where_filter,
    )
    from api.cli.fit_tool import tool_table, tool_toml, write_tool_file
    from models.fit import fit_power_law
    from models.tool import process_of, variables

    with errors():
        checked_process = process_of(process, "--process")
        band_kind = _band(band)
        coverage_factor = _coverage_factor(band_kind, k)
        if quantity is not None and quantity not in MODEL_QUANTITIES:
            known = ", ".join(MODEL_QUANTITIES)
            raise InputError("--quantity", quantity, f"unknown model quantity; known: {known}")
        if write_tool is not None:
            if quantity is None:
                raise InputError("--quantity", None, "required with --write-tool")
            if tool_name is None or not tool_name.strip():
                raise InputError("--tool-name", tool_name, "a non-empty name is required")
        life = _life_options(life_to_wear, wear, series)
        allowed = variables(checked_process)
        columns = _assignments(var or [], "--var", allowed, checked_process)
        fixed = {
            name: _exponent(text, name)
            for name, text in _assignments(fix or [], "--fix", allowed, checked_process).items()
        }
        for name, exponent in fixed.items():
            if name not in columns and exponent != 0.0:
                raise InputError(
                    f"--fix {name}", exponent, f"needs the values: add --var {name}=COLUMN"
                )

        table = read_csv(data)
        check_column(table, response, "--response", data)
        used = {response: "--response"}
        divided: dict[str, tuple[str, float]] = {}
        for name, spec in columns.items():
            column, divisor = _divided(spec, table, name, data)
            if column in used:
                raise InputError(f"--var {name}", column, f"column already used by {used[column]}")
            used[column] = f"--var {name}"
            divided[name] = (column, divisor)
        filters = [where_filter(item, table, data) for item in where or []]
        kept = select_rows(table, filters)
        filter_text = ", ".join(f"{c}={t}" for c, t in filters)
        never: list[str] = []
        if life is not None:
            limit_mm, wear_column, series_column = life
            kept, never = wear_lives(kept, series_column, response, wear_column, limit_mm, data)
        p = 1 + sum(1 for name in columns if name not in fixed)
        if len(kept) <= p:
            field, value = ("--where", filter_text) if filters else ("data file", str(data))
            raise InputError(
                field,
                value,
                f"leaves {_count(len(kept), 'row')} for {_count(p, 'parameter')} "
                f"(ln_K and {_count(p - 1, 'exponent')}); need at least {p + 1} to estimate s",
            )
        if life is None:
            rows = [f"row {i + 1}" for i in kept.index]
        else:
            rows = [f"{life[2]} {label}" for label in kept[life[2]]]
        y = positive_numbers(kept, response, rows)
        values = {
            name: positive_numbers(kept, column, rows) / divisor
            for name, (column, divisor) in divided.items()
        }
        result = fit_power_law(
            y,
            values,
            fixed=fixed,
            band=band_kind,
            k=coverage_factor if coverage_factor is not None else 2.0,
            response_name=response,
            labels=columns,
            rows=rows,
        )
        lived = "" if life is None else f", life to {life[1]} = {life[0]:g} mm"
        source = f"fit of {data.name} ({result.n} points, {filter_text or 'all rows'}{lived})"
        mapping = ", ".join(f"{c} → {n}" for n, c in columns.items())
        reference = (
            f"rcb fit: ln {response} = ln K + Σ e·ln x"
            f"{f' ({mapping})' if mapping else ''}; {result.describe()}"
        )
        written = None
        if write_tool is not None and quantity is not None and tool_name is not None:
            text = tool_toml(
                tool_table(result, tool_name, checked_process, quantity, source, reference)
            )
            write_tool_file(write_tool, text)
            written = str(write_tool)

    if as_json:
        payload: dict[str, Any] = {
            **result.to_json(),
            "response": response,
            "quantity": quantity,
            "process": checked_process,
            "columns": dict(columns),
            "where": [f"{c}={t}" for c, t in filters],
            "source": source,
            "reference": reference,
            "tool": tool_name if written else None,
            "written": written,
            "life_to_wear": None
            if life is None
            else {"limit_mm": life[0], "wear": life[1], "series": life[2], "never": never},
        }
        emit(payload)
    else:
        _out.print(_table(result, response, quantity, columns, source))
    for warning in fit_warnings(result, quantity or response):
        say(f"rcb: warning: {warning}")
    if never:
        say(f"rcb: {len(never)} tool(s) never reach the wear limit, left out: {', '.join(never)}")
    if written:
        say(f"rcb: wrote tool {tool_name} ({quantity}) to {written}")


def _life_options(
    limit_mm: float | None, wear: str | None, series: str | None
) -> tuple[float, str, str] | None:
    """``--life-to-wear`` with its columns (defaults ``VB``, ``case``: the NASA milling data)."""
    if limit_mm is None:
        for option, given in (("--wear", wear), ("--series", series)):
            if given is not None:
                raise InputError(option, given, "applies with --life-to-wear only")
        return None
    if not (math.isfinite(limit_mm) and limit_mm > 0):
        raise InputError("--life-to-wear", limit_mm, "a flank wear [mm] > 0, e.g. 0.3")
    return limit_mm, wear or "VB", series or "case"


def _divided(spec: str, table: Any, name: str, data: Path) -> tuple[str, float]:
    """``--var NAME=COLUMN`` or ``NAME=COLUMN/NUMBER``: the column and what to divide it by."""
    from api.cli.fit_data import check_column

    base, slash, number = spec.rpartition("/")
    if spec in table.columns or not slash or base.strip() not in table.columns:
        check_column(table, spec, f"--var {name}", data)
        return spec, 1.0
    try:
        divisor = float(number)
    except ValueError:
        raise InputError(f"--var {name}", spec, "COLUMN/NUMBER: the divisor is no number") from None
    if not (math.isfinite(divisor) and divisor > 0):
        raise InputError(f"--var {name}", spec, "COLUMN/NUMBER: the divisor must be > 0")
    return base.strip(), divisor


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _band(text: str) -> Band:
    from models.fit_band import BANDS

    for band in BANDS:
        if text == band:
            return band
    raise InputError("--band", text, f"unknown band; expected one of: {', '.join(BANDS)}")


def _coverage_factor(band: Band, k: float | None) -> float | None:
    if band == "range":
        if k is not None:
            raise InputError("--k", k, "applies to --band 2s only")
        return None
    if k is None:
        return 2.0
    if not (math.isfinite(k) and k > 0):
        raise InputError("--k", k, "the coverage factor must be a positive finite number")
    return k


def _assignments(
    items: list[str], option: str, allowed: tuple[str, ...], process: str
) -> dict[str, str]:
    """``NAME=TEXT`` items with NAME among the variables of ``process``."""
    result: dict[str, str] = {}
    for item in items:
        name, sep, text = item.partition("=")
        name, text = name.strip(), text.strip()
        if not sep or not name or not text:
            raise InputError(option, item, "must be NAME=VALUE")
        if name not in allowed:
            raise InputError(
                option,
                item,
                f"{name} is not a {process} variable; expected one of: {', '.join(allowed)}",
            )
        if name in result:
            raise InputError(option, item, f"{name} is given twice")
        result[name] = text
    return result


def _exponent(text: str, name: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"--fix {name}", text, "must be a number") from None
    if not math.isfinite(value):
        raise InputError(f"--fix {name}", text, "must be a finite number")
    return value


def _table(
    result: FitResult,
    response: str,
    quantity: str | None,
    columns: Mapping[str, str],
    source: str,
) -> Table:
    title = f"{quantity or response} = (K ± ΔK) · Π x^e"
    table = new_table(title=title, title_justify="left", caption=source, caption_justify="left")
    table.add_column("parameter")
    table.add_column("column")
    table.add_column("value", justify="right")
    table.add_column("std. error", justify="right")
    table.add_row("K", response, f"{result.K:.6g}", f"ln K ± {result.stderr['ln_K']:.4g}")
    band = "range" if result.band == "range" else f"{result.k:g}·s"
    table.add_row(f"ΔK ({band})", "", f"{result.dK:.6g}", f"ΔK/K = {result.dK / result.K:.4g}")
    for name, exponent in result.exponents.items():
        error = "fixed" if name in result.fixed else f"{result.stderr[name]:.4g}"
        table.add_row(name, columns.get(name, ""), f"{exponent:.6g}", error)
    table.add_section()
    table.add_row("n", "", f"{result.n}", "")
    table.add_row("s (ln)", "", f"{result.s:.4g}", "")
    table.add_row("R² (ln)", "", f"{result.r2:.4g}", "")
    table.add_row("coverage", "", f"{result.coverage:.4g}", "")
    table.add_row("max |r|/s", "", f"{result.max_abs_residual_s:.3g}", "")
    return table
