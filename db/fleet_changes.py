"""Whether a change of a plan's process its monitors counted keeps it out of the fleet (issue 32).

A part whose readings made the plan's monitors count a change of its process (a
``regime_change``) beyond those accepted, while none was pending, stores that part in
``plans.fleet_change_part`` (alembic 0022); the plan is out of the fleet from then
(:func:`db.fleet.local_evidence`: its changes exceed those accepted). The
:data:`~supervisor.fleet.changes.JUDGED_AFTER`-th part after it compares what the plan had
learned before that part with what it has learned since
(:func:`supervisor.fleet.changes.confirmed`): a change the readings do not confirm (a
monitor's false alarm) is accepted by itself, as ``rcb fleet include`` would accept it, and the
audit log says so (actor ``rcb``, action ``fleet change not confirmed``); a confirmed one stays
until an engineer accepts it (``plans.fleet_change_confirmed``, alembic 0023; audit action
``fleet change confirmed``, with the quantity whose law moved most and its ``z``).
``rcb fleet include`` and ``rcb replan --reset-bands`` clear the part. Cost: nothing on a part
while no change is pending or a confirmed one waits; while one waits to be judged, a count of
at most ``JUDGED_AFTER + 2`` of the plan's parts, and once the band states before it.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from db import tables as t
from db.audit import audit
from db.fleet_states import newest_state
from db.intake import PlanHead
from supervisor.fleet.changes import JUDGED_AFTER, counted, largest_shift, opens_change
from supervisor.rcb.posterior import Posterior
from supervisor.rcb.posterior import from_json as posterior_from_json
from supervisor.rcb.state import RcbState


def fleet_change(
    *, session: Session, plan: PlanHead, part_id: int, before: RcbState, after: RcbState
) -> dict[str, Any]:
    """The plan row's update for the fleet after part ``part_id`` (module docstring); {}: none."""
    if plan.fleet_change_part is None:
        if opens_change(before, after, plan.fleet_changes_accepted):
            return {"fleet_change_part": part_id}
        return {}
    if plan.fleet_change_confirmed:
        return {}  # waits for an engineer
    parts = (
        select(t.Part.id)
        .where(t.Part.plan_id == plan.id, t.Part.id >= plan.fleet_change_part)
        .limit(JUDGED_AFTER + 2)
        .subquery()
    )
    if session.scalar(select(func.count()).select_from(parts)) != JUDGED_AFTER + 1:
        return {}  # not yet
    shift = largest_shift(_before(session, plan.id), after.posterior)
    serial = session.scalar(select(t.Part.serial).where(t.Part.id == plan.fleet_change_part))
    detail = {
        "part": serial,  # the serial, as the surfaces name it (a-7); part_id the row's id
        "part_id": plan.fleet_change_part,
        "largest_shift": None if shift is None else shift.where,
        "z": None if shift is None or shift.z is None else round(shift.z, 3),
    }
    if shift is not None and shift.confirms:
        audit(
            session=session,
            actor="rcb",
            action="fleet change confirmed",
            target=f"plan {plan.id}",
            result="out of the fleet until rcb fleet include",
            detail=detail,
            plan_id=plan.id,
        )
        return {"fleet_change_confirmed": True}
    now = counted(after)
    audit(
        session=session,
        actor="rcb",
        action="fleet change not confirmed",
        target=f"plan {plan.id}",
        result="accepted",
        detail={**detail, "changes_accepted": now},
        plan_id=plan.id,
    )
    return {"fleet_change_part": None, "fleet_changes_accepted": now}


def _before(session: Session, plan_id: int) -> dict[tuple[str, str], Posterior | None]:
    """Per operation and tool quantity, the belief before the change's part."""
    rows = session.execute(
        select(t.Operation.name, t.ToolModel.quantity, t.BandState.posterior)
        .join(t.Plan, t.Operation.plan_id == t.Plan.id)
        .join(t.ToolModel, t.ToolModel.tool_id == t.Operation.tool_id)
        .outerjoin(t.BandState, t.BandState.id == newest_state(before_change=True))
        .where(t.Operation.plan_id == plan_id)
    ).all()
    return {(name, q): None if p is None else posterior_from_json(p) for name, q, p in rows}


def clear_fleet_change(row: t.Plan) -> None:
    """The plan's changes are accepted or forgotten: none is pending."""
    row.fleet_change_part = None
    row.fleet_change_confirmed = False


def plan_changes(*, session: Session, plan_ids: Iterable[int]) -> dict[int, int]:
    """Per plan, the changes of its process its monitors counted (every quantity, one statement).

    What ``rcb fleet include`` accepts (``plans.fleet_changes_accepted``) and what takes a plan
    out of the fleet when it grows beyond that: counted the same way for both, over the whole
    plan whichever tools a new plan asks for, since the last reset of its bands.
    """
    ids = sorted(set(plan_ids))
    if not ids:
        return {}
    b = t.BandState
    # a monitor's ``changes`` (:func:`supervisor.rcb.monitor_state.from_json`: 0 if absent),
    # summed in the database: the monitors are not decoded
    counted = func.coalesce(b.monitor["changes"].as_integer(), 0)
    rows = session.execute(
        select(t.Operation.plan_id, func.sum(counted))
        .join(t.ToolModel, t.ToolModel.tool_id == t.Operation.tool_id)
        .join(b, b.id == newest_state())
        .where(t.Operation.plan_id.in_(ids), b.monitor.is_not(None))
        .group_by(t.Operation.plan_id)
    ).all()
    out = dict.fromkeys(ids, 0)
    out.update({plan_id: int(total or 0) for plan_id, total in rows})
    return out
