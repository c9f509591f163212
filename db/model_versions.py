"""Versions of an operation's models (``operation_model_versions``): rows out, newest in.

A band change is a new row, never an update (:mod:`db.tables`); the row in force for an
operation and quantity is the one with the highest ``version``.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import Subquery, func, select
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
    """The newest model version per (operation id, quantity) of a plan: K, dK, exponents."""
    v = t.OperationModelVersion
    newest = _newest_versions(plan_id)
    rows = session.execute(
        select(v.operation_id, v.quantity, v.K, v.dK, v.exponents).join(
            newest,
            (v.operation_id == newest.c.operation_id)
            & (v.quantity == newest.c.quantity)
            & (v.version == newest.c.version),
        )
    )
    return {(row.operation_id, row.quantity): row for row in rows}


def version_numbers(*, session: Session, plan_id: int) -> dict[tuple[int, str], int]:
    """The newest model version number per (operation id, quantity) of a plan."""
    newest = _newest_versions(plan_id)
    rows = session.execute(select(newest.c.operation_id, newest.c.quantity, newest.c.version))
    return {(row.operation_id, row.quantity): row.version for row in rows}


def _newest_versions(plan_id: int) -> Subquery:
    """Subquery: the newest model version number per (operation id, quantity) of a plan."""
    v = t.OperationModelVersion
    return (
        select(v.operation_id, v.quantity, func.max(v.version).label("version"))
        .join(t.Operation, v.operation_id == t.Operation.id)
        .where(t.Operation.plan_id == plan_id)
        .group_by(v.operation_id, v.quantity)
        .subquery()
    )
