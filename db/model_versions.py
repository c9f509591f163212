"""Versions of an operation's models (``operation_model_versions``): rows out, newest in.

A band change is a new row, never an update (:mod:`db.tables`); the row in force for an
operation and quantity is the one with the highest ``version``.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import ScalarSelect, select
from sqlalchemy.orm import Session, aliased

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


def _newest_ids(session: Session, plan_id: int) -> list[ScalarSelect[int]]:
    """Per (operation, quantity) of the plan, a subquery: the id of its newest model version.

    The pairs come from the versions without a part (``initial``, ``replan``): few, indexed.
    """
    v = t.OperationModelVersion
    operations = select(t.Operation.id).where(t.Operation.plan_id == plan_id)
    rows = session.execute(
        select(v.operation_id, v.quantity).where(
            v.operation_id.in_(list(session.scalars(operations))), v.part_id.is_(None)
        )
    )
    pairs = {(int(operation_id), str(quantity)) for operation_id, quantity in rows}
    newest = []
    for operation_id, quantity in sorted(pairs):
        n = aliased(v)
        newest.append(
            select(n.id)
            .where(n.operation_id == operation_id, n.quantity == quantity)
            .order_by(n.version.desc())
            .limit(1)
            .scalar_subquery()
        )
    return newest
