"""Whether a change of a plan's process its monitors counted keeps it out of the fleet (issue 32).

A part whose readings made the plan's monitors count a change of its process (a
``regime_change``) while none was pending sets ``plans.fleet_change_part`` to that
part (alembic 0022). The plan's band states before it are what it had learned of the process
as it was; :func:`confirmed_changes` compares them with its newest
(:func:`supervisor.fleet.changes.confirmed`): a change its readings since confirm keeps the
plan out of the fleet (:func:`db.fleet.local_evidence`), one they do not (a monitor's false
alarm) leaves it in with everything it learned. ``rcb fleet include`` accepts the changes
(``plans.fleet_changes_accepted``) and clears the part; ``rcb replan --reset-bands`` clears
it with the count of changes.
"""

from __future__ import annotations

from collections.abc import Iterable

from sqlalchemy import select, update
from sqlalchemy.orm import Session, aliased

from db import tables as t
from db.fleet_states import newest_state
from supervisor.fleet.changes import confirmed
from supervisor.rcb.posterior import Posterior
from supervisor.rcb.posterior import from_json as posterior_from_json


def mark_fleet_change(*, session: Session, plan_id: int, part_id: int) -> None:
    """Part ``part_id`` counted a change: what the plan learned before it is the reference.

    A change already pending keeps its part (the beliefs before the first change not
    accepted are the ones compared). One statement, only for a part that counted a change.
    """
    cut = t.Plan.fleet_change_part
    session.execute(
        update(t.Plan).where(t.Plan.id == plan_id, cut.is_(None)).values({cut: part_id})
    )


def clear_fleet_change(row: t.Plan) -> None:
    """The plan's changes are accepted or forgotten: none is pending."""
    row.fleet_change_part = None


def confirmed_changes(*, session: Session, plan_ids: Iterable[int]) -> set[int]:
    """The plans among ``plan_ids`` whose pending change their readings since confirm.

    One statement for any number of plans: per operation and tool quantity the newest band
    state and the newest before the change's part (index seeks, :func:`db.fleet.newest_state`).
    A plan with no change pending is not among them.
    """
    ids = sorted(set(plan_ids))
    if not ids:
        return set()
    now, before = aliased(t.BandState), aliased(t.BandState)
    rows = session.execute(
        select(t.Operation.plan_id, before.posterior, now.posterior)
        .join(t.Plan, t.Operation.plan_id == t.Plan.id)
        .join(t.ToolModel, t.ToolModel.tool_id == t.Operation.tool_id)
        .join(now, now.id == newest_state())
        .outerjoin(before, before.id == newest_state(before_change=True))
        .where(t.Operation.plan_id.in_(ids), t.Plan.fleet_change_part.is_not(None))
    ).all()
    pairs: dict[int, list[tuple[Posterior | None, Posterior | None]]] = {}
    for plan_id, old, new in rows:
        pairs.setdefault(plan_id, []).append((_belief(old), _belief(new)))
    return {plan_id for plan_id, found in pairs.items() if confirmed(found)}


def _belief(stored: dict[str, object] | None) -> Posterior | None:
    return None if stored is None else posterior_from_json(stored)
