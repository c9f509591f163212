"""The machines whose models this database imported, by the names the fleet gives them.

``rcb fleet imported TOOL`` (``GET /tools/{name}/fleet/imported``) lists them a page at a time,
each in the fleet or taken out (and by whom, why), under the name an engineer takes one out by
(``rcb fleet exclude --machine lathe-1@6f1c2a3b``, :func:`db.fleet.abroad`). One grouped
statement on ``imported_models`` (by ``ix_imported_models_tool``, from the page's key on) and
one seek per name on ``fleet_exclusions``: no cost grows with the pages before.
:func:`imported_in_fleet` counts the tool's imported models whose machine is not taken out.
"""

from __future__ import annotations

from dataclasses import dataclass

from sqlalchemy import ColumnElement, and_, case, exists, func, literal, or_, select
from sqlalchemy.orm import Session

from db import tables as t
from db.fleet import abroad, taken_out


@dataclass(frozen=True)
class ImportedMachine:
    """An imported machine's models of a tool: how many, on how many readings, in or out."""

    machine: str
    models: int
    readings: int
    out: str  # why not in the fleet ("" where it is)


def imported_machines(
    *, session: Session, tool: str, after: tuple[str, str] | None, limit: int
) -> list[tuple[tuple[str, str], ImportedMachine]]:
    """Up to ``limit`` imported machines of ``tool`` after the key ``after``, each by its key.

    The key is the machine's stored (name, origin); the page's order is the keys'.
    """
    m = t.ImportedModel
    query = select(m.machine, m.origin, func.count(), func.sum(m.observations)).where(
        m.tool == tool
    )
    if after is not None:
        query = query.where(
            or_(m.machine > after[0], and_(m.machine == after[0], m.origin > after[1]))
        )
    groups = session.execute(
        query.group_by(m.machine, m.origin).order_by(m.machine, m.origin).limit(limit)
    ).all()
    named = [(abroad(machine, origin), machine, origin, n, r) for machine, origin, n, r in groups]
    out = taken_out(session=session, names=[name for name, *_ in named])
    return [
        (
            (machine, origin),
            ImportedMachine(name, int(count), int(readings or 0), out.get(name, "")),
        )
        for name, machine, origin, count, readings in named
    ]


def imported_in_fleet(*, session: Session, tool: str) -> int:
    """``tool``'s imported models whose machine no engineer took out (one counting statement).

    None: a new plan with no stored plan of the tool starts from the catalogue
    (``rcb fleet show`` says so), whatever was imported.
    """
    m, e = t.ImportedModel, t.FleetExclusion
    out = exists().where(e.machine == _abroad_name())
    found = session.scalar(select(func.count()).select_from(m).where(m.tool == tool, ~out))
    return int(found or 0)


def _abroad_name() -> ColumnElement[str]:
    """:func:`db.fleet.abroad` in SQL: ``machine@`` the origin's first 8 characters."""
    m = t.ImportedModel
    short = case((m.origin == "", literal("imported")), else_=func.substr(m.origin, 1, 8))
    return m.machine + literal("@") + short
