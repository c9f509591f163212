"""``rcb fit``'s data file: a CSV as text, its columns, filters, numbers, and tool lives.

Tool lives come from wear series (``--life-to-wear``, :func:`wear_lives`).

Every cell is read as text (so ``--where`` compares text); rows are counted from 1 after the
header line. Errors are :class:`models.errors.InputError` naming the option or the cell
(``Ra[row 3]``) and the value; a row of fewer fields than the header is refused as such
(``data file[row 6]``), not as the empty cells pandas would give it.
"""

from __future__ import annotations

import csv
from contextlib import suppress
from pathlib import Path

import numpy as np
import pandas as pd

from api.cli.common import number_cell
from models.bounds import MAX_CSV_BYTES, MAX_CSV_ROWS
from models.errors import InputError
from models.wear_life import series_lives

#: How many distinct values of a column an error lists at most.
_SHOWN_VALUES = 12


def read_csv(path: Path) -> pd.DataFrame:
    """Every cell as text (so ``--where`` compares text); empty cells are ``""``.

    A file over :data:`models.bounds.MAX_CSV_BYTES` is refused before it is read, one over
    :data:`models.bounds.MAX_CSV_ROWS` rows once it is.
    """
    with suppress(OSError):  # a missing or unreadable file: pandas says why below
        if path.is_file() and path.stat().st_size > MAX_CSV_BYTES:
            raise InputError("data file", str(path), f"is larger than {MAX_CSV_BYTES} bytes")
    try:
        table = pd.read_csv(path, dtype=str, keep_default_na=False, encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError("data file", str(path), "no such file") from None
    except IsADirectoryError:
        raise InputError("data file", str(path), "is a directory, not a CSV file") from None
    except UnicodeDecodeError as err:
        raise InputError("data file", str(path), f"is not UTF-8 text ({err.reason})") from None
    except pd.errors.EmptyDataError:
        raise InputError("data file", str(path), "is empty: no header line") from None
    except pd.errors.ParserError as err:
        first = str(err).strip().splitlines()[-1] if str(err).strip() else "unreadable"
        raise InputError("data file", str(path), f"is not a CSV table ({first})") from None
    except OSError as err:
        raise InputError("data file", str(path), f"cannot be read ({err.strerror})") from None
    table.columns = [str(c).strip() for c in table.columns]
    _refuse_short_rows(path, len(table.columns))
    if table.empty:
        raise InputError("data file", str(path), "has a header line but no rows")
    if len(table) > MAX_CSV_ROWS:
        why = f"has {len(table)} rows; at most {MAX_CSV_ROWS}"
        raise InputError("data file", str(path), why)
    return table


def _refuse_short_rows(path: Path, width: int) -> None:
    """Refuse a row of fewer fields than the header's ``width`` (pandas reads it as empty cells).

    Rows are counted as pandas counts them: from 1 after the header, blank lines skipped.
    """
    with path.open(encoding="utf-8-sig", newline="") as file:
        rows = (fields for fields in csv.reader(file) if fields)
        next(rows, None)  # the header
        for number, fields in enumerate(rows, start=1):
            if len(fields) < width:
                have = f"{len(fields)} field{'s' if len(fields) != 1 else ''}"
                raise InputError(
                    f"data file[row {number}]",
                    ",".join(fields),
                    f"has {have} where the header has {width}",
                )


def check_column(table: pd.DataFrame, column: str, option: str, path: Path) -> None:
    """Refuse a ``column`` the table of ``path`` does not have; the error lists the columns."""
    if column not in table.columns:
        raise InputError(
            option,
            column,
            f"no such column in {path.name}; columns: {', '.join(map(str, table.columns))}",
        )


def where_filter(item: str, table: pd.DataFrame, path: Path) -> tuple[str, str]:
    """``--where COLUMN=TEXT`` as ``(column, text)``, the column checked against the table."""
    column, sep, text = item.partition("=")
    column, text = column.strip(), text.strip()
    if not sep or not column:
        raise InputError("--where", item, "must be COLUMN=TEXT")
    if column not in table.columns:
        raise InputError(
            "--where",
            item,
            f"no column {column} in {path.name}; columns: {', '.join(map(str, table.columns))}",
        )
    return column, text


def select_rows(table: pd.DataFrame, filters: list[tuple[str, str]]) -> pd.DataFrame:
    """The rows whose cells match every ``(column, text)`` (cell text stripped of spaces)."""
    kept = table
    for i, (column, text) in enumerate(filters):
        matching = kept[kept[column].str.strip() == text]
        if matching.empty:
            after = " left by the --where before it" if i else ""
            raise InputError(
                "--where",
                f"{column}={text}",
                f"matches no row{after}; {column} holds: {_values(kept[column])}",
            )
        kept = matching
    return kept


def _values(cells: pd.Series) -> str:
    distinct = sorted({str(c).strip() for c in cells})
    shown = ", ".join(repr(v) for v in distinct[:_SHOWN_VALUES])
    return shown + (f" … ({len(distinct)} values)" if len(distinct) > _SHOWN_VALUES else "")


def positive_numbers(table: pd.DataFrame, column: str, rows: list[str]) -> np.ndarray:
    """The column as floats; a cell that is empty, not a number, not finite or ≤ 0 is refused."""
    cells = [str(c).strip() for c in table[column]]
    values = np.empty(len(cells))
    for i, cell in enumerate(cells):
        where = f"{column}[{rows[i]}]"
        value = number_cell(cell, where)
        if value <= 0:
            raise InputError(
                where, cell, "must be greater than 0 (the power law is fitted on logarithms)"
            )
        values[i] = value
    return values


def wear_lives(
    table: pd.DataFrame, series: str, time: str, wear: str, limit_mm: float, path: Path
) -> tuple[pd.DataFrame, list[str]]:
    """``--life-to-wear``: one row per tool, its ``time`` cell the life to ``limit_mm``.

    ``series`` labels each tool's rows, ``time`` and ``wear`` [mm] are its measurements (an
    empty wear cell: not measured then); :func:`models.wear_life.series_lives` finds the life.
    A tool's row is its first, so the columns constant per tool (cutting conditions) are kept.
    Returns the rows of the tools that reach the limit and the labels of those that never do.
    """
    for column, option in ((series, "--series"), (time, "--response"), (wear, "--wear")):
        check_column(table, column, option, path)
    labels = [str(c).strip() for c in table[series]]
    times, wears = np.empty(len(table)), np.empty(len(table))
    for i, (t, vb) in enumerate(zip(table[time], table[wear], strict=True)):
        row = f"row {table.index[i] + 1}"
        times[i] = number_cell(str(t), f"{time}[{row}]")
        if not str(vb).strip():
            wears[i] = np.nan
            continue
        wears[i] = number_cell(str(vb), f"{wear}[{row}]")
        if wears[i] < 0:
            raise InputError(f"{wear}[{row}]", str(vb).strip(), "flank wear cannot be negative")
    lives, never = series_lives(labels, times, wears, limit_mm)
    if not lives:
        top = np.nanmax(wears) if not np.all(np.isnan(wears)) else None
        raise InputError(
            "--life-to-wear", limit_mm, f"no {series} reaches it ({wear} at most {top} mm)"
        )
    first = table.assign(**{series: labels}).drop_duplicates(subset=series)
    reached = first[first[series].isin(list(lives))].copy()
    reached[time] = [repr(lives[label]) for label in reached[series]]
    return reached, [str(label) for label in never]
