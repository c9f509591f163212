"""Where a plan's evidence for the fleet stops when its process changes (issue 32).

A part whose readings made the plan's monitors count a change of its process (a
``regime_change``) while none was pending sets ``plans.fleet_evidence_before_part`` to that
part (alembic 0022): the fleet (:func:`db.fleet.local_evidence`) then reads the plan's band
states from before it, what the plan learned of the process as it was, and leaves out what
it learned since. ``rcb fleet include`` accepts the changes (``plans.fleet_changes_accepted``)
and clears it, so everything the plan learned is back; ``rcb replan --reset-bands`` clears it
with the count of changes. Why not out whole: in :mod:`db.fleet`'s docstring.
"""

from __future__ import annotations

from sqlalchemy import update
from sqlalchemy.orm import Session

from db import tables as t


def freeze_fleet_evidence(*, session: Session, plan_id: int, part_id: int) -> None:
    """Part ``part_id`` counted a change: the plan's fleet evidence stops before it.

    A change already pending keeps its part (the evidence stops at the first change not
    accepted). One statement, only for a part that counted a change.
    """
    cut = t.Plan.fleet_evidence_before_part
    session.execute(
        update(t.Plan).where(t.Plan.id == plan_id, cut.is_(None)).values({cut: part_id})
    )


def clear_fleet_change(row: t.Plan) -> None:
    """The plan's changes are accepted or forgotten: its fleet evidence runs to its newest."""
    row.fleet_evidence_before_part = None
