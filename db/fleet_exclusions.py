"""An engineer takes a plan or a machine out of the fleet, and puts it back (``rcb fleet``).

Excluded, a plan's (or every plan of a machine's) learned models no longer make any new
plan's prior (:func:`db.fleet.fleet_evidence`); a plan whose process changed is out by
itself until an engineer puts it back, accepting the changes it counted so far.
"""

from __future__ import annotations

from sqlalchemy import delete, select
from sqlalchemy.orm import Session

from db import tables as t
from db.fleet import imported_machine
from db.fleet_changes import plan_changes
from db.fleet_changes import clear_fleet_change
from db.plans import get_plan_row
from models.errors import InputError

#: The longest reason an exclusion keeps [characters]: a sentence or two, on every surface.
MAX_REASON = 500


def exclude(
    *, session: Session, plan_id: int | None, machine: str | None, reason: str, actor: str
) -> None:
    """Take ``plan_id`` or ``machine`` (one of them) out of the fleet.

    ``reason`` is kept with the exclusion and shown wherever it is: it must say something, in
    at most :data:`MAX_REASON` characters. Excluding what is already out changes nothing but
    the reason shown.
    """
    _one(plan_id, machine)
    text = reason.strip()
    if not text or len(text) > MAX_REASON:
        raise InputError("--reason", reason, f"give why, in 1 to {MAX_REASON} characters")
    if (
        machine is not None
        and session.scalar(select(t.Machine.id).where(t.Machine.name == machine)) is None
        and not imported_machine(session=session, name=machine)
    ):
        raise InputError(
            "--machine", machine, "no stored plan or imported model is of this machine"
        )
    if plan_id is not None and get_plan_row(session=session, plan_id=plan_id) is None:
        raise InputError("PLAN", plan_id, "no such plan")
    same = (
        t.FleetExclusion.plan_id == plan_id
        if machine is None
        else t.FleetExclusion.machine == machine
    )
    session.execute(delete(t.FleetExclusion).where(same))
    session.add(t.FleetExclusion(plan_id=plan_id, machine=machine, reason=text, actor=actor))


def include(*, session: Session, plan_id: int | None, machine: str | None) -> int:
    """Put ``plan_id`` or ``machine`` back; a plan's changes so far are accepted. Returns them."""
    _one(plan_id, machine)
    if machine is not None:
        session.execute(delete(t.FleetExclusion).where(t.FleetExclusion.machine == machine))
        return 0
    row = get_plan_row(session=session, plan_id=plan_id or 0, lock=True)
    if row is None:
        raise InputError("PLAN", plan_id, "no such plan")
    session.execute(delete(t.FleetExclusion).where(t.FleetExclusion.plan_id == plan_id))
    changes = plan_changes(session=session, plan_ids=[row.id])[row.id]
    row.fleet_changes_accepted = changes
    clear_fleet_change(row)
    return changes


def _one(plan_id: int | None, machine: str | None) -> None:
    if (plan_id is None) == (machine is None):
        raise InputError("--plan/--machine", None, "name exactly one of a plan and a machine")
