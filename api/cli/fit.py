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
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rich.console import Console
from rich.table import Table

from api.cli.common import JsonOption, MissingOptionError, emit, errors, say
from api.cli.fit_options import (
    BandOption,
    DataArgument,
    FixOption,
    KOption,
    LifeToWearOption,
    ProcessOption,
    QuantityOption,
    ResponseOption,
    SeriesOption,
    ToolNameOption,
    VarOption,
    WearOption,
    WhereOption,
    WriteToolOption,
)
from api.cli.tables import new_table
from models.errors import InputError
from models.quantities import MODEL_QUANTITIES

if TYPE_CHECKING:
    from api.cli.fit_rows import FitRows
    from models.fit import FitResult
    from models.fit_band import Band
    from models.kinematics import Process

_out = Console()


def fit(
    data: DataArgument,
    response: ResponseOption,
    var: VarOption = None,
    fix: FixOption = None,
    band: BandOption = "range",
    k: KOption = None,
    where: WhereOption = None,
    quantity: QuantityOption = None,
    process: ProcessOption = "turning",
    tool_name: ToolNameOption = None,
    write_tool: WriteToolOption = None,
    life_to_wear: LifeToWearOption = None,
    wear: WearOption = None,
    series: SeriesOption = None,
    as_json: JsonOption = False,
) -> None:
    """Fit Y = K·Π x^e by least squares on logarithms, with a band ±ΔK, from a CSV file.

    Rows in error messages are counted from 1 after the header line (blank lines skipped).
    """
    # imported here (pandas, NumPy): rcb --help and the other commands do not load them
    from api.cli.fit_checks import fit_warnings
    from api.cli.fit_rows import fit_rows
    from models.fit import fit_power_law

    with errors():
        options = _options(
            process, band, k, quantity, tool_name, write_tool, life_to_wear, wear, series
        )
        options = _with_variables(options, var or [], fix or [])
        chosen = fit_rows(data, response, options.columns, options.fixed, options.life, where or [])
        result = fit_power_law(
            chosen.y,
            chosen.values,
            fixed=options.fixed,
            band=options.band,
            k=options.coverage_factor if options.coverage_factor is not None else 2.0,
            response_name=response,
            labels=options.columns,
            rows=chosen.rows,
        )
        source, reference = _provenance(data, response, result, options, chosen)
        written = _write_tool(write_tool, quantity, tool_name, result, options, source, reference)

    if as_json:
        texts = (source, reference, written)
        emit(_payload(result, response, quantity, tool_name, options, chosen, *texts))
    else:
        _out.print(_table(result, response, quantity, options.columns))
        # under the table, not its caption: a caption wraps at the table's width (52 cells),
        # which split "(8 points, / material=1, …)"
        _out.print(source, highlight=False, markup=False)
    for warning in fit_warnings(result, quantity or response):
        say(f"rcb: warning: {warning}")
    if chosen.never:
        never = ", ".join(chosen.never)
        say(f"rcb: {len(chosen.never)} tool(s) never reach the wear limit, left out: {never}")
    if written:
        say(f"rcb: wrote tool {tool_name} ({quantity}) to {written}")


@dataclass(frozen=True)
class _Options:
    """The options of one ``rcb fit``, checked: its process, band and variables."""

    process: Process
    band: Band
    coverage_factor: float | None
    life: tuple[float, str, str] | None
    columns: dict[str, str]
    fixed: dict[str, float]


def _options(
    process: str,
    band: str,
    k: float | None,
    quantity: str | None,
    tool_name: str | None,
    write_tool: Path | None,
    life_to_wear: float | None,
    wear: str | None,
    series: str | None,
) -> _Options:
    """The options checked in the order they are reported, the variables still to come."""
    from models.tool import process_of

    checked_process = process_of(process, "--process")
    band_kind = _band(band)
    coverage_factor = _coverage_factor(band_kind, k)
    _check_tool_options(quantity, tool_name, write_tool)
    life = _life_options(life_to_wear, wear, series)
    return _Options(checked_process, band_kind, coverage_factor, life, columns={}, fixed={})


def _check_tool_options(
    quantity: str | None, tool_name: str | None, write_tool: Path | None
) -> None:
    """``--quantity`` is a model quantity; ``--write-tool`` needs it and a ``--tool-name``."""
    if quantity is not None and quantity not in MODEL_QUANTITIES:
        known = ", ".join(MODEL_QUANTITIES)
        raise InputError("--quantity", quantity, f"unknown model quantity; known: {known}")
    if write_tool is not None:
        if quantity is None:
            raise MissingOptionError("--quantity", "required with --write-tool")
        if tool_name is None:
            raise MissingOptionError("--tool-name", "required with --write-tool")
        if not tool_name.strip():
            raise InputError("--tool-name", tool_name, "a non-empty name is required")


def _with_variables(options: _Options, var: list[str], fix: list[str]) -> _Options:
    """``options`` with the columns of ``--var`` and the exponents of ``--fix``, checked."""
    from models.tool import variables

    allowed = variables(options.process)
    columns = _assignments(var, "--var", allowed, options.process)
    fixed = {
        name: _exponent(text, name)
        for name, text in _assignments(fix, "--fix", allowed, options.process).items()
    }
    for name, exponent in fixed.items():
        if name not in columns and exponent != 0.0:
            raise InputError(
                f"--fix {name}", exponent, f"needs the values: add --var {name}=COLUMN"
            )
    return replace(options, columns=columns, fixed=fixed)


def _provenance(
    data: Path, response: str, result: FitResult, options: _Options, chosen: FitRows
) -> tuple[str, str]:
    """The model's ``source`` (the data and rows) and ``reference`` (the fit) texts."""
    life = options.life
    lived = "" if life is None else f", life to {life[1]} = {life[0]:g} mm"
    source = f"fit of {data.name} ({result.n} points, {chosen.filter_text or 'all rows'}{lived})"
    mapping = ", ".join(f"{c} → {n}" for n, c in options.columns.items())
    reference = (
        f"rcb fit: ln {response} = ln K + Σ e·ln x"
        f"{f' ({mapping})' if mapping else ''}; {result.describe()}"
    )
    return source, reference


def _write_tool(
    write_tool: Path | None,
    quantity: str | None,
    tool_name: str | None,
    result: FitResult,
    options: _Options,
    source: str,
    reference: str,
) -> str | None:
    """With ``--write-tool``: write the model as a plan-file tool; where it was written."""
    from api.cli.fit_tool import tool_table, tool_toml, write_tool_file

    if write_tool is None or quantity is None or tool_name is None:
        return None
    text = tool_toml(tool_table(result, tool_name, options.process, quantity, source, reference))
    write_tool_file(write_tool, text)
    return str(write_tool)


def _payload(
    result: FitResult,
    response: str,
    quantity: str | None,
    tool_name: str | None,
    options: _Options,
    chosen: FitRows,
    source: str,
    reference: str,
    written: str | None,
) -> dict[str, Any]:
    """What ``--json`` prints: the fit and the options it was made with."""
    life = options.life
    return {
        **result.to_json(),
        "response": response,
        "quantity": quantity,
        "process": options.process,
        "columns": dict(options.columns),
        "where": [f"{c}={t}" for c, t in chosen.filters],
        "source": source,
        "reference": reference,
        "tool": tool_name if written else None,
        "written": written,
        "life_to_wear": None
        if life is None
        else {"limit_mm": life[0], "wear": life[1], "series": life[2], "never": chosen.never},
    }


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
) -> Table:
    title = f"{quantity or response} = (K ± ΔK) · Π x^e"
    table = new_table(title=title, title_justify="left")
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
