"""A plan's models: those in force now, and every model version a page at a time.

A page of versions costs the same statements at any size of the database: index range reads
of the page's rows; the models in force, an index seek per (operation, quantity).
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import Engine

from api.services.errors import NotFoundError
from api.services.read.common import LIST_PAGE, _bounded, _plan, _read, _token, _untoken
from db import model_versions as versions
from db import tables as t
from db.read.plans import operations
from db.table_base import as_utc


def models_in_force(*, engine: Engine, plan_id: int) -> dict[str, Any]:
    """Per operation and quantity the newest model version: K, ΔK, exponents, version, cause.

    An index seek per (operation, quantity): the rows read do not grow with the history.
    """
    with _read(engine) as session, session.begin():
        _plan(session, plan_id)
        ops = operations(session=session, plan_id=plan_id)
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
        ops = operations(session=session, plan_id=plan_id)
        if operation is not None and operation not in {op.name for op, _ in ops}:
            raise NotFoundError("operation", operation)
        position = {op.id: op.position for op, _ in ops if operation in (None, op.name)}
        names = {op.id: op.name for op, _ in ops}
        found = versions.pairs(session=session, operation_ids=sorted(position))
        if quantity is not None and quantity not in {q for _, q in found}:
            raise NotFoundError("quantity", quantity)  # as an unknown operation is
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


def _model_version(model: t.OperationModelVersion, serial: str | None) -> dict[str, Any]:
    return {
        "version": model.version,
        "K": model.K,
        "dK": model.dK,
        "exponents": dict(model.exponents),
        "cause": model.cause,
        "serial": serial,
        "created_at": as_utc(model.created_at),
    }
