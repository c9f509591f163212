"""Append-only rows of several tables in one statement on PostgreSQL.

A part report appends a dozen rows to each of three or four tables. ``executemany`` sends
them row by row (psycopg's pipeline: one Bind/Execute per row, each row's parameters adapted
in Python), which costs the server's process about 1 ms of CPU per table here. On PostgreSQL
:func:`insert_rows` sends every table's rows as one JSON array parameter and inserts them
all in one statement, with data-modifying CTEs::

    WITH t0 AS (INSERT INTO measurements (...) SELECT ... FROM json_to_recordset(CAST(:rows0
    AS json)) AS x(part_id INTEGER, ...)) INSERT INTO rcb_decisions (...) SELECT ...

The stored values are the same: floats travel as their shortest repr (``json.dumps``), which
PostgreSQL's ``float8`` input reads back exactly; ``json`` columns keep the text
``json.dumps`` gives them (SQLAlchemy's serialiser), and a Python ``None`` in one is stored as
JSON ``null``, as SQLAlchemy's ``JSON`` type does. Rows that this cannot carry exactly (not
every column given, different keys per row, non-finite floats, values ``json`` cannot
encode) and other databases go through ``executemany``.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Mapping, Sequence
from datetime import datetime
from typing import Any

from sqlalchemy import JSON, Connection, Table, TextClause, insert, text

Batch = tuple[Table, Sequence[Mapping[str, Any]]]

_statements: dict[tuple[tuple[str, tuple[str, ...]], ...], TextClause] = {}
_statements_lock = threading.Lock()


def insert_rows(connection: Connection, batches: Sequence[Batch]) -> None:
    """Insert each batch's rows into its table, in the connection's transaction."""
    batches = [(table, rows) for table, rows in batches if rows]
    if not batches:
        return
    if connection.dialect.name == "postgresql":
        shapes = [_shape(table, rows) for table, rows in batches]
        if all(shape is not None for shape in shapes):
            params = {f"rows{i}": _json(rows) for i, (_, rows) in enumerate(batches)}
            if all(value is not None for value in params.values()):
                columns = [shape for shape in shapes if shape is not None]
                connection.execute(_statement(connection, batches, columns), params)
                return
    for table, rows in batches:
        connection.execute(insert(table), list(rows))


def _shape(table: Table, rows: Sequence[Mapping[str, Any]]) -> tuple[str, ...] | None:
    """The columns of ``rows`` if every row gives every column but an autoincrement key."""
    columns = tuple(rows[0])
    wanted = {c.key for c in table.columns if not (c.primary_key and c.autoincrement)}
    if set(columns) != wanted or any(len(row) != len(columns) for row in rows):
        return None
    if any(row.keys() != rows[0].keys() for row in rows):
        return None
    return columns


def _json(rows: Sequence[Mapping[str, Any]]) -> str | None:
    try:
        return json.dumps(list(rows), allow_nan=False, default=_encode)
    except (TypeError, ValueError):  # NaN or infinity, or a value JSON has no form for
        return None


def _encode(value: object) -> str:
    if isinstance(value, datetime):
        return value.isoformat()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def _statement(
    connection: Connection, batches: Sequence[Batch], shapes: Sequence[tuple[str, ...]]
) -> TextClause:
    key = tuple((table.name, shape) for (table, _), shape in zip(batches, shapes, strict=True))
    with _statements_lock:
        statement = _statements.get(key)
    if statement is not None:
        return statement
    dialect = connection.dialect
    quote = dialect.identifier_preparer.quote
    parts = []
    for i, ((table, _), shape) in enumerate(zip(batches, shapes, strict=True)):
        names = ", ".join(quote(c) for c in shape)
        values = ", ".join(
            f"COALESCE(x.{quote(c)}, CAST('null' AS json))"
            if isinstance(table.c[c].type, JSON)
            else f"x.{quote(c)}"
            for c in shape
        )
        types = ", ".join(f"{quote(c)} {table.c[c].type.compile(dialect=dialect)}" for c in shape)
        parts.append(
            f"INSERT INTO {quote(table.name)} ({names}) SELECT {values} "
            f"FROM json_to_recordset(CAST(:rows{i} AS json)) AS x({types})"
        )
    ctes = [f"t{i} AS ({sql})" for i, sql in enumerate(parts[:-1])]
    sql = (f"WITH {', '.join(ctes)} " if ctes else "") + parts[-1]
    statement = text(sql)
    with _statements_lock:
        _statements[key] = statement
    return statement
