"""The machines whose models this database imported, by the names the fleet gives them.

``rcb fleet show TOOL`` lists them beside the plans here, each in the fleet or taken out (and
by whom, why), under the name an engineer takes one out by (``rcb fleet exclude --machine
lathe-1@6f1c2a3b``, :func:`db.fleet.abroad`). One grouped statement on ``imported_models`` (by
``ix_imported_models_tool``) and one seek per name on ``fleet_exclusions``; at most
:data:`MAX_SHOWN` machines.
"""

from __future__ import annotations

from dataclasses import dataclass

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from db import tables as t
from db.fleet import abroad

#: The most imported machines a page names (a plant's whole fleet of one tool is far fewer).
MAX_SHOWN = 100


@dataclass(frozen=True)
class ImportedMachine:
    """An imported machine's models of a tool: how many, on how many readings, in or out."""

    machine: str
    models: int
    readings: int
    out: str  # why not in the fleet ("" where it is)


def imported_machines(*, session: Session, tool: str) -> tuple[list[ImportedMachine], bool]:
    """The first :data:`MAX_SHOWN` imported machines of ``tool`` by name, and whether more."""
    m = t.ImportedModel
    groups = session.execute(
        select(m.machine, m.origin, func.count(), func.sum(m.observations))
        .where(m.tool == tool)
        .group_by(m.machine, m.origin)
        .order_by(m.machine, m.origin)
        .limit(MAX_SHOWN + 1)
    ).all()
    named = [
        (abroad(machine, origin), count, readings) for machine, origin, count, readings in groups
    ]
    names = sorted({name for name, _, _ in named[:MAX_SHOWN]})
    why: dict[str, str] = {}
    if names:
        e = t.FleetExclusion
        for machine, actor, reason in session.execute(
            select(e.machine, e.actor, e.reason).where(e.machine.in_(names)).order_by(e.id)
        ):
            why[str(machine)] = f"taken out by {actor}: {reason}"
    shown = [
        ImportedMachine(name, int(count), int(readings or 0), why.get(name, ""))
        for name, count, readings in named[:MAX_SHOWN]
    ]
    return shown, len(groups) > MAX_SHOWN
