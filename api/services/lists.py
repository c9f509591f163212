"""The lists a page at a time: plans, tools, a plan's model versions; the models in force.

Every list takes ``page_size`` (the REST ``limit``, 1 to :data:`MAX_PAGE`) and an opaque
``cursor`` (the ``next_cursor`` of the previous page; null on the last page). A page costs
the same statements at any size of the database: index range reads of the page's rows.
"""

from __future__ import annotations

import base64
import binascii
import json
from typing import Any

from sqlalchemy import Engine

from api.services import to_json
from api.services.errors import NotFoundError
from api.services.reading import MAX_PAGE, _cursor, _plan, _read, _utc
from db import history, library
from db import model_versions as versions
from db import tables as t
from models.catalogue import catalogue
from models.errors import InputError

#: Plans, tools or model versions on a page unless asked otherwise.
LIST_PAGE = 100
#: Longest cursor of a list keyed by text (a tool's name is at most 200 characters).
MAX_CURSOR = 1200


def list_plans(
    *,
    engine: Engine,
    cursor: str | None = None,
    page_size: int = LIST_PAGE,
    only: frozenset[int] | None = None,
) -> dict[str, Any]:
    """A page of plans by id: machine, current setpoint version and part count.

    ``only``: just these plan ids (a key scoped to plans), filtered in the query, so its page
    is full and names no other plan.
    """
    _bounded(page_size)
    after = _cursor(cursor)
    with _read(engine) as session, session.begin():
        rows = history.plans(session=session, after_id=after, limit=page_size + 1, only=only)
    more = len(rows) > page_size
    rows = rows[:page_size]
    return {"plans": rows, "next_cursor": str(rows[-1]["id"]) if more else None}


def list_tools(
    *, engine: Engine, cursor: str | None = None, page_size: int = LIST_PAGE
) -> dict[str, Any]:
    """A page of the packaged catalogue and the stored tools, by name (code-point order).

    A stored tool replaces a catalogue tool of its name. Only the page's stored tools are read.
    """
    _bounded(page_size)
    after = str(_untoken(cursor, 1)[0]) if cursor is not None else ""  # names are not empty
    with _read(engine) as session, session.begin():
        stored = library.load_tools(session=session, after=after, limit=page_size + 1)
    packaged = {n: tool for n, tool in catalogue().items() if n > after}
    names = sorted({*packaged, *stored})
    if len(stored) > page_size:  # stored names past the last one read might come before
        names = [n for n in names if n <= max(stored)]
    tools = {**packaged, **stored}
    page = names[:page_size]
    more = len(names) > page_size
    return {
        "tools": [to_json.tool_json(tools[n]) for n in page],
        "next_cursor": _token([page[-1]]) if more else None,
    }


def models_in_force(*, engine: Engine, plan_id: int) -> dict[str, Any]:
    """Per operation and quantity the newest model version: K, ΔK, exponents, version, cause.

    An index seek per (operation, quantity): the rows read do not grow with the history.
    """
    with _read(engine) as session, session.begin():
        _plan(session, plan_id)
        ops = history.operations(session=session, plan_id=plan_id)
        rows = versions.in_force(session=session, plan_id=plan_id)
    latest: dict[int, dict[str, dict[str, Any]]] = {}
    for model, serial in sorted(rows, key=lambda r: (r[0].operation_id, r[0].quantity)):
        latest.setdefault(model.operation_id, {})[model.quantity] = _model_version(model, serial)
    return {
        "plan_id": plan_id,
        "operations": [
            {"name": op.name, "tool": tool.name, "models": latest.get(op.id, {})}
            for op, tool in ops
        ],
    }


def model_versions(
    *,
    engine: Engine,
    plan_id: int,
    operation: str | None = None,
    quantity: str | None = None,
    cursor: str | None = None,
    page_size: int = LIST_PAGE,
) -> dict[str, Any]:
    """A page of the plan's model versions, optionally of one operation and/or quantity.

    By version number, then operation (plan order), then quantity; ``next_cursor`` continues
    after the page's last version (with the same filters). Each (operation, quantity) is an
    index range read of at most a page (:func:`db.model_versions.versions_page`).
    """
    _bounded(page_size)
    mark = _untoken(cursor, 3) if cursor is not None else None
    with _read(engine) as session, session.begin():
        _plan(session, plan_id)
        ops = history.operations(session=session, plan_id=plan_id)
        if operation is not None and operation not in {op.name for op, _ in ops}:
            raise NotFoundError("operation", operation)
        position = {op.id: op.position for op, _ in ops if operation in (None, op.name)}
        names = {op.id: op.name for op, _ in ops}
        found = versions.pairs(session=session, operation_ids=sorted(position))
        listed = sorted(
            ((position[o], q, o) for o, q in found if quantity in (None, q)),
        )
        starts = [(o, q, _least((p, q), mark)) for p, q, o in listed]
        rows = versions.versions_page(session=session, starts=starts, limit=page_size + 1)
    more = len(rows) > page_size
    rows = rows[:page_size]
    last = rows[-1][0] if rows else None
    return {
        "plan_id": plan_id,
        "versions": [
            {"operation": names[m.operation_id], "quantity": m.quantity, **_model_version(m, s)}
            for m, s in rows
        ],
        "next_cursor": (
            _token([last.version, position[last.operation_id], last.quantity])
            if more and last is not None
            else None
        ),
    }


def _least(pair: tuple[int, str], mark: list[Any] | None) -> int:
    """The least version of ``pair`` (operation position, quantity) after the cursor's mark."""
    if mark is None:
        return 0
    version, at, quantity = int(mark[0]), int(mark[1]), str(mark[2])
    return version if pair > (at, quantity) else version + 1


def _bounded(page_size: int) -> None:
    if not 1 <= page_size <= MAX_PAGE:
        raise InputError("limit", page_size, f"must be between 1 and {MAX_PAGE}")


def _token(values: list[Any]) -> str:
    """An opaque cursor: the values as JSON, base64url without padding."""
    text = json.dumps(values, separators=(",", ":"), ensure_ascii=False)
    return base64.urlsafe_b64encode(text.encode("utf-8")).decode("ascii").rstrip("=")


def _untoken(cursor: str, size: int) -> list[Any]:
    """The values of a cursor of :func:`_token` (``size`` of them); else InputError on cursor."""
    refused = InputError("cursor", cursor, "not a cursor returned by this endpoint")
    if len(cursor) > MAX_CURSOR:
        raise refused
    try:
        raw = base64.urlsafe_b64decode(cursor + "=" * (-len(cursor) % 4))
        values = json.loads(raw.decode("utf-8"))
    except (binascii.Error, ValueError, RecursionError):  # and the Unicode, JSON errors
        raise refused from None
    kinds = (int, int, str) if size == 3 else (str,)
    if not isinstance(values, list) or len(values) != size:
        raise refused
    if not all(
        isinstance(v, k) and not isinstance(v, bool) for v, k in zip(values, kinds, strict=True)
    ):
        raise refused
    if size == 3 and not (0 <= values[0] <= t.MAX_INT and 0 <= values[1] <= t.MAX_INT):
        raise refused
    return values


def _model_version(model: t.OperationModelVersion, serial: str | None) -> dict[str, Any]:
    return {
        "version": model.version,
        "K": model.K,
        "dK": model.dK,
        "exponents": dict(model.exponents),
        "cause": model.cause,
        "serial": serial,
        "created_at": _utc(model.created_at),
    }
