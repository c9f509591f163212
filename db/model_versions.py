"""Versions of an operation's models (``operation_model_versions``): rows out, newest in.

A band change is a new row, never an update (:mod:`db.tables`); the row in force for an
operation and quantity is the one with the highest ``version``.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import ScalarSelect, select, union_all
from sqlalchemy.orm import Session

from db import tables as t
from models.powerlaw import PowerLawModel


def model_version_row(
    operation_id: int, model: PowerLawModel, version: int, cause: str, part_id: int | None
) -> dict[str, Any]:
    """The ``operation_model_versions`` row of ``model``, every column but the key given.

    ``cause``: ``initial``, ``part`` (with ``part_id``) or ``replan``.
    """
    return {
        "operation_id": operation_id,
        "quantity": model.quantity,
        "version": version,
        "K": model.K,
        "dK": model.dK,
        "exponents": dict(model.exponents),
        "cause": cause,
        "part_id": part_id,
        "created_at": t.utcnow(),
    }


def latest_models(*, session: Session, plan_id: int) -> dict[tuple[int, str], Any]:
    """The newest model version per (operation id, quantity) of a plan: K, dK, exponents.

    An index seek per (operation, quantity) on ``(operation_id, quantity, version)``: the rows
    read do not grow with the plan's history.
    """
    v = t.OperationModelVersion
    rows = session.execute(
        select(v.operation_id, v.quantity, v.K, v.dK, v.exponents, v.version).where(
            v.id.in_(_newest_ids(session, plan_id))
        )
    )
    return {(row.operation_id, row.quantity): row for row in rows}


def version_numbers(*, session: Session, plan_id: int) -> dict[tuple[int, str], int]:
    """The newest model version number per (operation id, quantity) of a plan."""
    return {
        key: row.version for key, row in latest_models(session=session, plan_id=plan_id).items()
    }


def in_force(*, session: Session, plan_id: int) -> list[tuple[t.OperationModelVersion, str | None]]:
    """The newest model version per (operation, quantity) of a plan, with its part's serial.

    An index seek per (operation, quantity), as :func:`latest_models`.
    """
    v = t.OperationModelVersion
    rows = session.execute(
        select(v, t.Part.serial)
        .outerjoin(t.Part, v.part_id == t.Part.id)
        .where(v.id.in_(_newest_ids(session, plan_id)))
    )
    return [(row, serial) for row, serial in rows]


def pairs(*, session: Session, operation_ids: list[int]) -> list[tuple[int, str]]:
    """The (operation id, quantity) pairs with model versions, sorted.

    They come from the versions without a part (``initial``, ``replan``): few, indexed by
    ``(operation_id, part_id, quantity)``.
    """
    if not operation_ids:
        return []
    v = t.OperationModelVersion
    rows = session.execute(
        select(v.operation_id, v.quantity).where(
            v.operation_id.in_(operation_ids), v.part_id.is_(None)
        )
    )
    return sorted({(int(operation_id), str(quantity)) for operation_id, quantity in rows})


#: Most (operation, quantity) branches in one statement of :func:`versions_page` (SQLite takes
#: at most 500 terms in a compound SELECT).
_BRANCHES = 200


def versions_page(
    *, session: Session, starts: list[tuple[int, str, int]], limit: int
) -> list[tuple[t.OperationModelVersion, str | None]]:
    """Up to ``limit`` model versions by version number, with their part's serial.

    Parameters
    ----------
    starts : list of (operation id, quantity, least version)
        The pairs to list, in the order versions of the same number are listed, each from
        its least version number on.
    limit : int
        Most versions returned. Each pair is an index range read of at most ``limit`` rows
        on ``(operation_id, quantity, version)``: the cost grows with the page and the number
        of pairs, never with the history.
    """
    v = t.OperationModelVersion
    rank = {(o, q): i for i, (o, q, _) in enumerate(starts)}
    heads: list[Any] = []
    for first in range(0, len(starts), _BRANCHES):
        branches = [
            select(v.id, v.version, v.operation_id, v.quantity)
            .where(v.operation_id == o, v.quantity == q, v.version >= least)
            .order_by(v.version)
            .limit(limit)
            .subquery()
            for o, q, least in starts[first : first + _BRANCHES]
        ]
        heads += session.execute(union_all(*(select(b) for b in branches))).all()
    heads.sort(key=lambda h: (h.version, rank[(h.operation_id, h.quantity)]))
    ids = [int(h.id) for h in heads[:limit]]
    if not ids:
        return []
    rows = session.execute(
        select(v, t.Part.serial).outerjoin(t.Part, v.part_id == t.Part.id).where(v.id.in_(ids))
    )
    found = {row.id: (row, serial) for row, serial in rows}
    return [found[i] for i in ids]


def _newest_ids(session: Session, plan_id: int) -> list[ScalarSelect[int]]:
    """Per (operation, quantity) of the plan, a subquery: the id of its newest model version.

    On a Core alias made once (:data:`_NEWER`): an ORM ``aliased`` entity per pair cost 1 ms
    of column adaptation each, most of a part report's time (benchmarks/report_speed.py).
    """
    n = _NEWER.c
    operations = select(t.Operation.id).where(t.Operation.plan_id == plan_id)
    return [
        select(n.id)
        .where(n.operation_id == operation_id, n.quantity == quantity)
        .order_by(n.version.desc())
        .limit(1)
        .scalar_subquery()
        for operation_id, quantity in pairs(
            session=session, operation_ids=list(session.scalars(operations))
        )
    ]


#: The model versions as the subqueries of :func:`_newest_ids` read them.
_NEWER = t.core_table(t.OperationModelVersion).alias("newer")
