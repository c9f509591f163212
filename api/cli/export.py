"""``rcb export``: a plan's record as tidy tables (:mod:`api.report.export`), csv or parquet.

Streamed: the parts are read a page at a time (:func:`api.services.read.plan_parts.part_pages`)
and so is the setpoint history (:func:`api.services.read.history.history_pages`), each page
appended to its four files and let go, so memory does not grow with the plan's life. Each
file is written whole or not at all (:func:`api.cli.atomic.written_atomically`): an error
half-way leaves no file, and a file that was there before stays as it was.
"""

from __future__ import annotations

import sys
from contextlib import ExitStack, suppress
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from api.cli.atomic import AtomicFile, written_atomically
from api.cli.common import DbOption, PlanArg, engine_of, errors, plan_of, say
from models.errors import InputError

if TYPE_CHECKING:
    import pandas as pd
    import pyarrow as pa

#: The tables, in the order they are written.
NAMES = ("parts", "measurements", "decisions", "setpoints")


def export(
    plan: PlanArg,
    out: Annotated[Path, typer.Option("--out", help="Directory to write the tables into.")],
    fmt: Annotated[str, typer.Option("--format", help="csv or parquet.")] = "csv",
    db: DbOption = None,
) -> None:
    """Parts, measurements, decisions and setpoint history as tidy tables (one row each)."""
    from api.report import export as tidy
    from api.services.read import history as read_history
    from api.services.read import plan_parts as read_parts

    with errors():
        if fmt not in ("csv", "parquet"):
            raise InputError("--format", fmt, "expected csv or parquet")
        engine = engine_of(db)
        plan_key = plan_of(engine, plan)
        _directory(out)
        paths = {name: out / f"{name}.{fmt}" for name in NAMES}
        with ExitStack() as stack:
            tables = {}
            for name, path in paths.items():
                tables[name] = _Table(name, stack.enter_context(written_atomically(path)), fmt)
                stack.callback(tables[name].discard)  # before its file is closed and removed
            for page in read_parts.part_pages(engine=engine, plan_id=plan_key):
                for name, frame in tidy.part_frames(plan_key, page).items():
                    tables[name].add(frame)
            for history in read_history.history_pages(engine=engine, plan_id=plan_key):
                tables["setpoints"].add(tidy.setpoint_frame(history["versions"]))
            for table in tables.values():
                table.close()
    for path in paths.values():
        say(f"rcb: wrote {path}")
    sys.stdout.flush()


def _directory(out: Path) -> None:
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputError(
            "--out", str(out), f"cannot create the directory ({err.strerror})"
        ) from None


class _Table:
    """One table's file, a page at a time; its columns and their types are the first page's.

    csv: a header, then each page's rows (:func:`api.report.export.csv_bytes`); parquet: a
    row group per page, of the types :func:`api.report.export.column_types` gives.
    """

    def __init__(self, name: str, file: AtomicFile, fmt: str) -> None:
        self._name, self._file, self._fmt = name, file, fmt
        self._columns: list[str] | None = None
        self._parquet: Any = None

    def add(self, frame: pd.DataFrame) -> None:
        """Append ``frame``'s rows (the first frame names the columns, even with no rows)."""
        from api.report.export import csv_bytes

        if self._columns is None:
            self._columns = list(frame.columns)
            self._start()
        elif self._columns != list(frame.columns):
            frame = self._aligned(frame)
        if frame.empty:
            return
        if self._fmt == "csv":
            self._file.write(csv_bytes(frame, header=False))
        else:
            self._parquet.write_table(_arrow(frame, self._parquet.schema))

    def close(self) -> None:
        """Finish the file (a table no page reached has its columns and no row)."""
        if self._columns is None:
            self.add(_empty(self._name))
        if self._parquet is not None:
            self._parquet.close()
            self._parquet = None

    def discard(self) -> None:
        """After an error: let the parquet writer go (its file is removed, not finished)."""
        if self._parquet is not None:
            with suppress(Exception):  # the error that stopped the export is the one to tell
                self._parquet.close()
            self._parquet = None

    def _start(self) -> None:
        from api.report.export import column_types, csv_bytes

        assert self._columns is not None
        if self._fmt == "csv":
            import pandas as pd

            self._file.write(csv_bytes(pd.DataFrame(columns=self._columns)))
            return
        import pyarrow as pa
        import pyarrow.parquet as pq

        arrow = {
            "int64": pa.int64(),
            "float64": pa.float64(),
            "string": pa.string(),
            "bool": pa.bool_(),
            "timestamp": pa.timestamp("us", tz="UTC"),
        }
        types = column_types(self._name, self._columns)
        schema = pa.schema([(c, arrow[types[c]]) for c in self._columns])
        self._parquet = pq.ParquetWriter(self._file.raw, schema)

    def _aligned(self, frame: pd.DataFrame) -> pd.DataFrame:
        """``frame`` in the first page's columns; a column the first page lacked is an error."""
        assert self._columns is not None
        extra = [c for c in frame.columns if c not in self._columns]
        if extra:  # every version sets every operation: a page has the first page's columns
            raise RuntimeError(f"{self._name}: a later page has columns {extra}")
        return frame.reindex(columns=self._columns)


def _arrow(frame: pd.DataFrame, schema: pa.Schema) -> pa.Table:
    import pyarrow as pa

    return pa.Table.from_pandas(frame, schema=schema, preserve_index=False)


def _empty(name: str) -> pd.DataFrame:
    import pandas as pd

    from api.report.export import COLUMNS, SETPOINT_HEAD

    return pd.DataFrame(columns=list(COLUMNS.get(name, SETPOINT_HEAD)))
