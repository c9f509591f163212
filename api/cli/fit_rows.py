"""The rows ``rcb fit`` (:mod:`api.cli.fit`) fits: read, filtered, checked and divided.

Imported when ``rcb fit`` runs (it loads pandas and NumPy through :mod:`api.cli.fit_data`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from api.cli.fit_data import (
    check_column,
    positive_numbers,
    read_csv,
    select_rows,
    wear_lives,
    where_filter,
)
from models.errors import InputError


@dataclass(frozen=True)
class FitRows:
    """The rows of the data file a fit uses: the response, the variables and the row labels."""

    y: Any
    values: dict[str, Any]
    rows: list[str]
    filters: list[tuple[str, str]]
    filter_text: str
    never: list[str]


def fit_rows(
    data: Path,
    response: str,
    columns: Mapping[str, str],
    fixed: Mapping[str, float],
    life: tuple[float, str, str] | None,
    where: list[str],
) -> FitRows:
    """Read ``data``, keep the rows of every ``--where`` (or each tool's life) and check them."""
    table = read_csv(data)
    check_column(table, response, "--response", data)
    divided = _divisions(table, response, columns, data)
    filters = [where_filter(item, table, data) for item in where]
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
    return FitRows(y, values, rows, filters, filter_text, never)


def _divisions(
    table: Any, response: str, columns: Mapping[str, str], data: Path
) -> dict[str, tuple[str, float]]:
    """Each ``--var``'s column and divisor; no column used twice (nor the response's)."""
    used = {response: "--response"}
    divided: dict[str, tuple[str, float]] = {}
    for name, spec in columns.items():
        column, divisor = _divided(spec, table, name, data)
        if column in used:
            raise InputError(f"--var {name}", column, f"column already used by {used[column]}")
        used[column] = f"--var {name}"
        divided[name] = (column, divisor)
    return divided


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
