"""Plans as a review reads them: a page of plan summaries, a plan's operations with their tools.

Each returns plain rows or dicts; :mod:`api.services.read.plans` shapes them for JSON.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import func, or_, select
from sqlalchemy.orm import Session

from db import tables as t
from db.plan_state import settings_listed
from db.table_base import as_utc

#: The settings a plan summary shows as fields of its own, not under ``settings``.
_OWN_FIELDS = ("strategy", "alpha")


def plans(
    *, session: Session, after_id: int = 0, limit: int = 100, only: frozenset[int] | None = None
) -> list[dict[str, Any]]:
    """Up to ``limit`` plans with id > ``after_id``, by id: machine, setpoint version, parts.

    ``only``: just these plan ids (a key scoped to plans), filtered in the query, so a page is
    never short for it. One statement: the plans by primary key, each plan's part count an
    index-only count of its own parts (``parts (plan_id, serial)``), never a whole-table read.
    """
    counted = (
        select(func.count())
        .select_from(t.Part)
        .where(t.Part.plan_id == t.Plan.id)
        .correlate(t.Plan)
        .scalar_subquery()
    )
    query = (
        select(t.Plan, t.Machine.name, counted)
        .join(t.Machine, t.Plan.machine_id == t.Machine.id)
        .where(t.Plan.id > after_id)
    )
    if only is not None:
        query = query.where(t.Plan.id.in_(sorted(only)))
    rows = session.execute(query.order_by(t.Plan.id).limit(limit)).all()
    return [summary(plan, machine, n or 0) for plan, machine, n in rows]


def summary(plan: t.Plan, machine: str, parts: int) -> dict[str, Any]:
    """The fields a plan list shows (strategy and alpha beside the other settings)."""
    settings, refused = settings_listed(plan)
    return {
        "id": plan.id,
        "name": plan.name,
        "machine": machine,
        "strategy": settings["strategy"],
        "alpha": settings["alpha"],
        "settings": {k: v for k, v in settings.items() if k not in _OWN_FIELDS},
        "status": "halted" if plan.halt is not None else "running",
        "halt": plan.halt,
        "settings_refused": refused,  # a stored value a later check refuses
        "setpoint_version": plan.current_setpoint_version,
        "parts": parts,
        "created_at": as_utc(plan.created_at),
    }


def operations(*, session: Session, plan_id: int) -> list[tuple[t.Operation, t.Tool]]:
    """A plan's operations in order, with their tools."""
    return [
        (op, tool)
        for op, tool in session.execute(
            select(t.Operation, t.Tool)
            .join(t.Tool, t.Operation.tool_id == t.Tool.id)
            .where(t.Operation.plan_id == plan_id)
            .order_by(t.Operation.position)
        ).all()
    ]


def numbered_names(*, session: Session, name: str) -> set[str]:
    """The stored plan names ``name`` and ``name-N`` (what a new ``name-N`` must not repeat)."""
    escaped = name.replace("\\", "\\\\").replace("%", "\\%").replace("_", "\\_")
    return set(
        session.scalars(
            select(t.Plan.name).where(
                or_(t.Plan.name == name, t.Plan.name.like(f"{escaped}-%", escape="\\"))
            )
        )
    )
