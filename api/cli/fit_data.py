"""``rcb fit``'s data file: a CSV read as text, its columns, ``--where`` filters, numbers.

Every cell is read as text (so ``--where`` compares text); rows are counted from 1 after the
header line. Errors are :class:`models.errors.InputError` naming the option or the cell
(``Ra[row 3]``) and the value.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from api.cli.common import number_cell
from models.errors import InputError

#: How many distinct values of a column an error lists at most.
_SHOWN_VALUES = 12


def read_csv(path: Path) -> pd.DataFrame:
    """Every cell as text (so ``--where`` compares text); empty cells are ``""``."""
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
    if table.empty:
        raise InputError("data file", str(path), "has a header line but no rows")
    return table


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
