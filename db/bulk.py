"""Append-only rows of several tables, and updates by primary key, in one statement on PostgreSQL.

A part report appends a dozen rows to each of three or four tables. ``executemany`` sends
them row by row (psycopg's pipeline: one Bind/Execute per row, each row's parameters adapted
in Python), which costs the server's process about 1 ms of CPU per table here. On PostgreSQL
:func:`write_rows` sends every table's rows as one JSON array parameter and inserts them
all in one statement, with data-modifying CTEs::

    WITH t0 AS (INSERT INTO measurements (...) SELECT ... FROM json_to_recordset(CAST(:rows0
    AS json)) AS x(part_id INTEGER, ...)) INSERT INTO rcb_decisions (...) SELECT ...

The stored values are the same: floats travel as their shortest repr (``json.dumps``), which
PostgreSQL's ``float8`` input reads back exactly; ``json`` columns keep the text
``json.dumps`` gives them (SQLAlchemy's serialiser), and a Python ``None`` in one is stored as
JSON ``null``, as SQLAlchemy's ``JSON`` type does (SQL NULL in a column ``JSON(none_as_null=
True)``). Rows that this cannot carry exactly (not
every column given, different keys per row, non-finite floats, values ``json`` cannot
encode) and other databases go through ``executemany``. An update is the same: each
row gives the primary key and the columns to set, and ``UPDATE ... FROM json_to_recordset``
sets them (``WITH tN AS (UPDATE plans AS u SET ... FROM json_to_recordset(...) AS x(...)
WHERE u.id = x.id)``).

A JSON column's value that is already encoded (:class:`Encoded`: a part report's answer, which
the service also sends over HTTP) is placed in the statement's JSON as its text, not encoded
again; elsewhere its value is stored as usual.

A use case can :func:`defer` rows to its session and send them with the rows it adds last
(:func:`write_deferred`): a part report's rows, its plan's new pointers, its idempotency
record and its audit entry then travel in one statement. Nothing read in the transaction
may depend on deferred rows. The rows wait on the session's connection (``Connection.info``);
rows still deferred when that connection commits are written before it does, and a rollback
or the connection's return to the pool forgets them, so a forgotten :func:`write_deferred`
cannot lose them. These hooks are registered on the project's engines where they are made
(:func:`hook_engine`, called by :func:`db.engine.make_engine`), not on every SQLAlchemy
session of the process; :func:`defer` refuses a session of any other engine.
"""

from __future__ import annotations

import json
import secrets
import threading
import weakref
from collections.abc import Mapping, Sequence
from datetime import datetime
from typing import Any

from sqlalchemy import (
    JSON,
    Connection,
    Engine,
    Table,
    TextClause,
    bindparam,
    event,
    insert,
    text,
    update,
)
from sqlalchemy.orm import Session
from sqlalchemy.pool import Pool

Batch = tuple[Table, Sequence[Mapping[str, Any]]]


class Encoded:
    """A JSON column's value with its JSON text (``json.dumps(value)``, what SQLAlchemy stores)."""

    __slots__ = ("value", "text")

    def __init__(self, value: Any, text: str) -> None:
        self.value, self.text = value, text

    @classmethod
    def of(cls, value: Any) -> Encoded:
        """``value`` with its text (non-finite floats refused, as in a JSON column)."""
        return cls(value, json.dumps(value, allow_nan=False))


_statements: dict[tuple[tuple[bool, str, tuple[str, ...]], ...], TextClause] = {}
_statements_lock = threading.Lock()
#: The key of a connection's deferred inserts and updates in ``Connection.info``.
_DEFERRED = "rcb_deferred_rows"
#: The pools of the engines :func:`hook_engine` was given.
_HOOKED: weakref.WeakSet[Pool] = weakref.WeakSet()


def write_rows(
    connection: Connection, inserts: Sequence[Batch] = (), updates: Sequence[Batch] = ()
) -> None:
    """Insert rows and update rows by primary key, in the connection's transaction.

    ``inserts``: batches of rows to append to each batch's table. ``updates``: batches of rows
    that each give a table's primary key and the columns to set in that row (the same columns
    in every row of a batch). On PostgreSQL all of them go in one statement.
    """
    work = [(False, table, rows) for table, rows in inserts if rows]
    work += [(True, table, rows) for table, rows in updates if rows]
    if not work:
        return
    if connection.dialect.name == "postgresql":
        shapes = [_shape(table, rows, is_update) for is_update, table, rows in work]
        if all(shape is not None for shape in shapes):
            params = {f"rows{i}": _json(rows) for i, (_, _, rows) in enumerate(work)}
            if all(value is not None for value in params.values()):
                columns = [shape for shape in shapes if shape is not None]
                connection.execute(_statement(connection, work, columns), params)
                return
    for is_update, table, rows in work:
        rows = [_decoded(row) for row in rows]
        if is_update:
            _update_each(connection, table, rows)
        else:
            connection.execute(insert(table), rows)


def _decoded(row: Mapping[str, Any]) -> Mapping[str, Any]:
    """The row with each :class:`Encoded` value replaced by the value itself."""
    if not any(isinstance(v, Encoded) for v in row.values()):
        return row
    return {k: v.value if isinstance(v, Encoded) else v for k, v in row.items()}


def hook_engine(engine: Engine) -> None:
    """Let sessions of ``engine`` defer rows: each commit writes them, a rollback forgets them."""
    event.listen(engine, "commit", _write_left_over)
    event.listen(engine, "rollback", _forget)
    event.listen(engine.pool, "checkin", _forget_on_checkin)
    _HOOKED.add(engine.pool)


def defer(session: Session, batches: Sequence[Batch] = (), updates: Sequence[Batch] = ()) -> None:
    """Keep rows to insert and rows to update for :func:`write_deferred` (same transaction)."""
    connection = session.connection()
    if connection.engine.pool not in _HOOKED:
        raise RuntimeError("db.bulk.defer: the session's engine was not made by db.engine")
    inserts, later = connection.info.setdefault(_DEFERRED, ([], []))
    inserts.extend(batches)
    later.extend(updates)


def write_deferred(session: Session, batches: Sequence[Batch] = ()) -> None:
    """Write the session's deferred rows and ``batches``, on PostgreSQL in one statement."""
    connection = session.connection()
    inserts, updates = connection.info.pop(_DEFERRED, ([], []))
    write_rows(connection, [*inserts, *batches], updates)


def _write_left_over(connection: Connection) -> None:
    """Before a connection commits: write the rows still deferred on it."""
    left = connection.info.pop(_DEFERRED, None)
    if left is not None:
        write_rows(connection, *left)


def _forget(connection: Connection) -> None:
    connection.info.pop(_DEFERRED, None)


def _forget_on_checkin(_dbapi_connection: Any, record: Any) -> None:
    record.info.pop(_DEFERRED, None)


def _shape(
    table: Table, rows: Sequence[Mapping[str, Any]], is_update: bool = False
) -> tuple[str, ...] | None:
    """The columns of ``rows`` if every row gives every column but an autoincrement key.

    For an update: if every row gives the primary key and the same other columns.
    """
    columns = tuple(rows[0])
    if is_update:
        keys = {c.key for c in table.primary_key.columns}
        if not keys <= set(columns) or not set(columns) - keys:
            return None
    else:
        wanted = {c.key for c in table.columns if not (c.primary_key and c.autoincrement)}
        if set(columns) != wanted:
            return None
    first = rows[0].keys()
    if any(row.keys() != first for row in rows):
        return None
    return columns


def _update_each(connection: Connection, table: Table, rows: Sequence[Mapping[str, Any]]) -> None:
    """``executemany`` of an update by primary key (the fallback of :func:`write_rows`)."""
    keys = [c.key for c in table.primary_key.columns]
    if not rows or any(set(keys) - set(row) for row in rows):
        raise ValueError(f"{table.name}: an update row must give the primary key {keys}")
    statement = update(table).where(*(table.c[k] == bindparam(f"key_{k}") for k in keys))
    statement = statement.values({c: bindparam(f"set_{c}") for c in rows[0] if c not in keys})
    connection.execute(
        statement,
        [{(f"key_{c}" if c in keys else f"set_{c}"): v for c, v in row.items()} for row in rows],
    )


def _json(rows: Sequence[Mapping[str, Any]]) -> str | None:
    """The rows as one JSON array; None if a value has no JSON form (NaN, infinity, other).

    An :class:`Encoded` value goes in as a placeholder string that is then replaced by its
    text: a random nonce makes the placeholder unlike any string in the rows.
    """
    nonce = secrets.token_hex(8)
    encoded: list[Encoded] = []

    def encode(value: object) -> str:
        if isinstance(value, datetime):
            return value.isoformat()
        if isinstance(value, Encoded):
            encoded.append(value)
            return f"{nonce}:{len(encoded) - 1}"
        raise TypeError(f"{type(value).__name__} is not JSON serialisable")

    try:
        text = json.dumps(list(rows), allow_nan=False, default=encode)
    except (TypeError, ValueError):
        return None
    for i, value in enumerate(encoded):
        text = text.replace(f'"{nonce}:{i}"', value.text, 1)
    return text


def _statement(
    connection: Connection,
    work: Sequence[tuple[bool, Table, Sequence[Mapping[str, Any]]]],
    shapes: Sequence[tuple[str, ...]],
) -> TextClause:
    key = tuple(
        (is_update, table.name, shape)
        for (is_update, table, _), shape in zip(work, shapes, strict=True)
    )
    with _statements_lock:
        statement = _statements.get(key)
    if statement is not None:
        return statement
    dialect = connection.dialect
    quote = dialect.identifier_preparer.quote
    parts = []
    for i, ((is_update, table, _), shape) in enumerate(zip(work, shapes, strict=True)):
        value = {
            c: f"COALESCE(x.{quote(c)}, CAST('null' AS json))"
            if _null_is_json(table.c[c].type)
            else f"x.{quote(c)}"
            for c in shape
        }
        types = ", ".join(f"{quote(c)} {table.c[c].type.compile(dialect=dialect)}" for c in shape)
        source = f"json_to_recordset(CAST(:rows{i} AS json)) AS x({types})"
        if is_update:
            keys = [c.key for c in table.primary_key.columns]
            sets = ", ".join(f"{quote(c)} = {value[c]}" for c in shape if c not in keys)
            match = " AND ".join(f"u.{quote(k)} = x.{quote(k)}" for k in keys)
            parts.append(f"UPDATE {quote(table.name)} AS u SET {sets} FROM {source} WHERE {match}")
        else:
            names = ", ".join(quote(c) for c in shape)
            values = ", ".join(value[c] for c in shape)
            parts.append(f"INSERT INTO {quote(table.name)} ({names}) SELECT {values} FROM {source}")
    ctes = [f"t{i} AS ({sql})" for i, sql in enumerate(parts[:-1])]
    sql = (f"WITH {', '.join(ctes)} " if ctes else "") + parts[-1]
    statement = text(sql)
    with _statements_lock:
        _statements[key] = statement
    return statement


def _null_is_json(column_type: Any) -> bool:
    """Whether a column stores Python's None as JSON ``null`` (a ``JSON`` column's default)."""
    return isinstance(column_type, JSON) and not column_type.none_as_null
