"""``rcb milling``: constant-load milling setup from constant-feed tests (Tai, Tsai & Li 2023).

``rcb milling setup TESTS.csv`` fits ``I = A + B·f + k1·VB`` (Tai et al. Eq. 14) to the tests and
prints the reference current and the feed-rate limits of :func:`supervisor.constant_load.
constant_load_setup`. The CSV has a header line with the columns ``feed_rate_mm_min``,
``spindle_current_A`` and one of ``flank_wear_um`` or ``flank_wear_mm`` (both at once is
refused as ambiguous); other columns (a test label, a date) are ignored. Rows are counted from 1
after the header line, blank lines skipped.

``--strength-force-N F --force-calibration CAL.toml`` adds the robust bound: the reference current
is at most the largest current whose upper force band stays under F. The calibration file holds
one ``linear_current`` calibration table at its top level, in the plan-file format of
:mod:`models.sensors` (TOML, or JSON when the name ends in ``.json``).

Errors follow ``rcb`` (exit 2, one line ``rcb: error: FIELD = VALUE: reason``;
:func:`api.cli.common.errors`).
"""

from __future__ import annotations

import csv
import io
import json
import math
import tomllib
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

from api.cli.common import MissingOptionError, emit, errors, number_cell
from api.cli.tables import new_table
from models.errors import InputError
from models.sensors import calibration_to_mapping, linear_current_calibration_from_mapping
from supervisor.constant_load import (
    PAPER_SAFETY_FACTOR,
    ConstantLoadSetup,
    FeedLimit,
    ForceLimit,
    constant_load_setup,
)

_out = Console()

FEED, CURRENT = "feed_rate_mm_min", "spindle_current_A"
#: Flank wear columns and their factor to mm.
WEAR_COLUMNS = {"flank_wear_um": 1e-3, "flank_wear_mm": 1.0}
_FILE = "TESTS.csv"


_TestsArg = Annotated[
    Path,
    typer.Argument(
        metavar=_FILE,
        help="Constant-feed tests: feed_rate_mm_min, spindle_current_A, flank_wear_um "
        "(or flank_wear_mm).",
    ),
]


def setup(
    tests: _TestsArg,
    safety_factor: Annotated[
        float,
        typer.Option("--safety-factor", help="Reference current / largest current withstood."),
    ] = PAPER_SAFETY_FACTOR,
    wear_interval_um: Annotated[
        str,
        typer.Option(
            "--wear-interval-um", help="Flank wear at tool change: SHARP,WORN in µm (Tai §II.G)."
        ),
    ] = "180,220",
    max_current_A: Annotated[
        float | None,
        typer.Option(
            "--max-current-A", help="Largest current the tool withstood [A] (default: the data's)."
        ),
    ] = None,
    strength_force_N: Annotated[
        float | None,
        typer.Option("--strength-force-N", help="Tool strength [N] (needs --force-calibration)."),
    ] = None,
    force_calibration: Annotated[
        Path | None,
        typer.Option(
            "--force-calibration",
            help="A linear_current calibration (TOML or JSON) converting current to force.",
        ),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of a table.")] = False,
) -> None:
    """Reference current and upper/lower feed limits for constant-load milling (Tai §II.F)."""
    with errors():
        if not (math.isfinite(safety_factor) and 0 < safety_factor <= 1):
            raise InputError("--safety-factor", safety_factor, "must be in (0, 1] (Tai: 0.85)")
        if max_current_A is not None and not (math.isfinite(max_current_A) and max_current_A > 0):
            raise InputError("--max-current-A", max_current_A, "must be a current > 0")
        interval = _interval(wear_interval_um)
        strength = _strength(strength_force_N, force_calibration)
        feeds, currents, wears = read_tests(tests)
        result = constant_load_setup(
            feeds,
            currents,
            wears,
            safety_factor=safety_factor,
            wear_interval_mm=interval,
            max_current_A=max_current_A,
            strength=strength,
            source=f"fit of {tests.name} ({len(feeds)} cuts)",
        )
    if as_json:
        emit(setup_json(result))
    else:
        _out.print(_table(result, tests.name))


def setup_json(result: ConstantLoadSetup) -> dict[str, Any]:
    """The ``--json`` document of a setup (bands expanded, coverage ``coverage_k``)."""

    def limit(feed: FeedLimit) -> dict[str, float]:
        return {"value": feed.feed_rate_mm_min, "band": feed.band_mm_min}

    return {
        "reference_current_A": result.reference_current_A,
        "max_current_A": result.max_current_A,
        "safety_factor": result.safety_factor,
        "strength_current_A": result.strength_current_A,
        "governed_by": result.governed_by,
        "feed_rate_upper_mm_min": limit(result.upper),
        "feed_rate_lower_mm_min": limit(result.lower),
        "flank_wear_at_lower_limit_mm": {
            "value": result.lower.flank_wear_mm,
            "band": result.lower.flank_wear_band_mm,
        },
        "wear_interval_mm": list(result.wear_interval_mm),
        "coverage_k": result.coverage_k,
        "calibration": calibration_to_mapping(result.calibration),
    }


def _interval(text: str) -> tuple[float, float]:
    """``SHARP,WORN`` in µm → mm; the order is checked by the setup."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) != 2:
        raise InputError("--wear-interval-um", text, "must be SHARP,WORN in µm, e.g. 180,220")
    values = []
    for part in parts:
        try:
            value = float(part)
        except ValueError:
            raise InputError("--wear-interval-um", text, f"{part!r} is not a number") from None
        if not math.isfinite(value) or value < 0:
            raise InputError("--wear-interval-um", text, "flank wears must be finite and >= 0")
        values.append(value)
    if values[0] > values[1]:
        raise InputError("--wear-interval-um", text, "reversed: give the sharp end first")
    return values[0] / 1000.0, values[1] / 1000.0


def _strength(force_N: float | None, path: Path | None) -> ForceLimit | None:
    if force_N is None and path is None:
        return None
    if path is None:
        raise MissingOptionError("--force-calibration", "required with --strength-force-N")
    if force_N is None:
        raise MissingOptionError("--strength-force-N", "required with --force-calibration")
    if not (math.isfinite(force_N) and force_N > 0):
        raise InputError("--strength-force-N", force_N, "must be a force > 0")
    data = _read_mapping(path)
    calibration = linear_current_calibration_from_mapping(data, "--force-calibration")
    return ForceLimit(force_N, calibration)


def _read_mapping(path: Path) -> object:
    field = "--force-calibration"
    text = _text(path, field, "utf-8", "is a directory")
    try:
        return json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as err:
        first = str(err).splitlines()[0] if str(err).strip() else "unreadable"
        raise InputError(field, str(path), f"cannot be parsed ({first})") from None


def _text(path: Path, field: str, encoding: str, directory: str) -> str:
    """The file's text; errors name ``field`` and the path (``directory``: what a dir gets)."""
    try:
        return path.read_text(encoding=encoding)
    except FileNotFoundError:
        raise InputError(field, str(path), "no such file") from None
    except IsADirectoryError:
        raise InputError(field, str(path), directory) from None
    except UnicodeDecodeError as err:
        raise InputError(field, str(path), f"is not UTF-8 text ({err.reason})") from None
    except OSError as err:
        raise InputError(field, str(path), f"cannot be read ({err.strerror})") from None


def read_tests(path: Path) -> tuple[list[float], list[float], list[float]]:
    """Feed rates [mm/min], currents [A] and flank wears [mm] of a tests CSV, checked.

    Errors name the file, or the column and row (``spindle_current_A[row 3]``).
    """
    rows = _rows(path)
    header = [cell.strip() for cell in rows[0]]
    for name in header:
        if header.count(name) > 1:
            raise InputError(_FILE, str(path), f"column {name!r} appears twice")
    wear_columns = [name for name in WEAR_COLUMNS if name in header]
    if len(wear_columns) > 1:
        raise InputError(
            _FILE, str(path), "has both flank_wear_um and flank_wear_mm: ambiguous, keep one"
        )
    for name in (FEED, CURRENT, *(wear_columns or ["flank_wear_um (or flank_wear_mm)"])):
        if name not in header:
            raise InputError(
                _FILE, str(path), f"no column {name}; columns: {', '.join(header) or '(none)'}"
            )
    wear = wear_columns[0]
    columns: dict[str, list[float]] = {FEED: [], CURRENT: [], wear: []}
    for row_number, row in enumerate(rows[1:], start=1):
        if len(row) != len(header):
            raise InputError(
                f"{_FILE}[row {row_number}]",
                ",".join(row),
                f"has {len(row)} cells, the header has {len(header)}",
            )
        for name, values in columns.items():
            values.append(_cell(row[header.index(name)], f"{name}[row {row_number}]", name == FEED))
    factor = WEAR_COLUMNS[wear]
    return columns[FEED], columns[CURRENT], [w * factor for w in columns[wear]]


def _rows(path: Path) -> list[list[str]]:
    text = _text(path, _FILE, "utf-8-sig", "is a directory, not a CSV file")
    try:
        rows = [row for row in csv.reader(io.StringIO(text)) if any(c.strip() for c in row)]
    except csv.Error as err:
        raise InputError(_FILE, str(path), f"is not a CSV table ({err})") from None
    if not rows:
        raise InputError(_FILE, str(path), "is empty: no header line")
    if len(rows) == 1:
        raise InputError(_FILE, str(path), "has a header line but no rows")
    return rows


def _cell(text: str, where: str, positive: bool) -> float:
    value = number_cell(text, where)
    if positive and value <= 0:
        raise InputError(where, text.strip(), "must be greater than 0")
    if value < 0:
        raise InputError(where, text.strip(), "must be at least 0")
    return value


def _table(result: ConstantLoadSetup, name: str) -> Table:
    cal, k = result.calibration, result.coverage_k
    table = new_table(
        title="Constant-load milling setup (Tai, Tsai & Li 2023, §II.F)",
        title_justify="left",
        caption=f"fit of {name}: {cal.n} cuts; bands ±{k:g}·u (single cut)",
        caption_justify="left",
    )
    table.add_column("quantity")
    table.add_column("value", justify="right")
    table.add_column("band", justify="right")
    table.add_column("basis")
    ref_basis = (
        f"{result.safety_factor:g} × max current"
        if result.governed_by == "safety_factor"
        else "force band at the strength limit"
    )
    table.add_row("reference current [A]", f"{result.reference_current_A:.4f}", "", ref_basis)
    table.add_row("max current withstood [A]", f"{result.max_current_A:.4f}", "", "")
    if result.strength_current_A is not None:
        table.add_row("strength current [A]", f"{result.strength_current_A:.4f}", "", "")
    table.add_row(
        "upper feed limit [mm/min]",
        f"{result.upper.feed_rate_mm_min:.1f}",
        f"±{result.upper.band_mm_min:.1f}",
        "sharp tool at the reference (Eq. 13)",
    )
    lo, hi = (1000 * w for w in result.wear_interval_mm)
    table.add_row(
        "lower feed limit [mm/min]",
        f"{result.lower.feed_rate_mm_min:.1f}",
        f"±{result.lower.band_mm_min:.1f}",
        f"worn end {hi:g} µm + band (Eq. 15)",
    )
    table.add_row(
        "flank wear at lower limit [µm]",
        f"{1000 * result.lower.flank_wear_mm:.1f}",
        f"±{1000 * result.lower.flank_wear_band_mm:.1f}",
        f"tool-change interval {lo:g}-{hi:g} µm",
    )
    table.add_section()
    for label, value, u in (
        ("A idle current [A]", cal.idle_current_A, cal.u_idle_current_A),
        ("B [A/(mm/min)]", cal.slope_A_per_mm_min, cal.u_slope_A_per_mm_min),
        ("k1 [A/mm]", cal.wear_coefficient_A_per_mm, cal.u_wear_coefficient_A_per_mm),
    ):
        table.add_row(label, f"{value:.5g}", f"u {u:.2g}", "Eq. 14 fit")
    table.add_row("s residual [A]", f"{cal.residual_sd_A:.2g}", "", "")
    return table
