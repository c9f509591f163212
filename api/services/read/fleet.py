"""A tool's fleet: its plans, in the fleet or why not, and what they learned of its law.

``rcb fleet show`` and ``rcb fleet law``. A page of plans by id
(:func:`db.fleet_members.members`); the cursor is the last plan's id.
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

from sqlalchemy import Engine, func, select
from sqlalchemy.orm import Session

from api.services.errors import NotFoundError
from api.services.read.common import (
    LIST_PAGE,
    _bounded,
    _read,
    _token,
    _untoken,
    ordered_cursor,
    ordered_value,
)
from db import tables as t
from db.fleet_imported import imported_in_fleet, imported_machines
from db.fleet_law import tool_law
from db.fleet_members import members
from models.catalogue import catalogue
from supervisor.fleet.law import FleetLaw


def fleet_members(
    *,
    engine: Engine,
    tool: str,
    cursor: str | None = None,
    page_size: int = LIST_PAGE,
    only: frozenset[int] | None = None,
    newest: bool = False,
) -> dict[str, Any]:
    """A page of the plans using ``tool``: each in the fleet (``out`` empty) or why not.

    ``only``: just these plans (a key scoped to plans sees no other plan's name).
    ``newest``: newest first (the cursor then pages down the ids).

    ``imported``: the learned models of the tool other databases exported and this one
    imported (``rcb models import``); :func:`imported_fleet` names their machines.
    ``imported_in_fleet``: of those, the models of machines not taken out.
    """
    _bounded(page_size)
    after = ordered_value(cursor, newest=newest)
    with _read(engine) as session, session.begin():
        _known(session, tool)
        rows = members(
            session=session,
            tool=tool,
            after_id=after,
            limit=page_size + 1,
            only=only,
            newest_first=newest,
        )
        imported = session.scalar(
            select(func.count()).select_from(t.ImportedModel).where(t.ImportedModel.tool == tool)
        )
        in_fleet = imported_in_fleet(session=session, tool=tool) if imported else 0
    more = len(rows) > page_size
    rows = rows[:page_size]
    return {
        "tool": tool,
        "plans": [{**asdict(m), "in_fleet": not m.out} for m in rows],
        "imported": int(imported or 0),
        "imported_in_fleet": in_fleet,
        "next_cursor": ordered_cursor(rows[-1].plan_id, newest=newest) if more else None,
    }


def imported_fleet(
    *,
    engine: Engine,
    tool: str,
    cursor: str | None = None,
    page_size: int = LIST_PAGE,
    only: frozenset[int] | None = None,
) -> dict[str, Any]:
    """A page of the machines of ``tool``'s imported models, by the names the fleet gives them.

    Each in the fleet (``out`` empty) or taken out, by whom and why (:mod:`db.fleet_imported`).
    A key scoped to plans sees none: they are no plans of this database.
    """
    _bounded(page_size)
    after = None if cursor is None else tuple(str(v) for v in _untoken(cursor, 2))
    with _read(engine) as session, session.begin():
        _known(session, tool)
        rows = (
            []
            if only is not None
            else imported_machines(
                session=session,
                tool=tool,
                after=(after[0], after[1]) if after else None,
                limit=page_size + 1,
            )
        )
    more = len(rows) > page_size
    rows = rows[:page_size]
    return {
        "tool": tool,
        "machines": [{**asdict(m), "in_fleet": not m.out} for _, m in rows],
        "next_cursor": _token(list(rows[-1][0])) if more else None,
    }


def fleet_law(*, engine: Engine, tool: str) -> dict[str, Any]:
    """What the fleet learned of ``tool``'s law, per quantity, beside the catalogue's.

    From the evidence new plans' fleet priors read (:func:`db.fleet_law.tool_law`); counts, no
    plan's or machine's name. ``quantities`` empty: no plan in the fleet measured the tool,
    and new plans start from the catalogue.
    """
    with _read(engine) as session, session.begin():
        _known(session, tool)
        laws = tool_law(session=session, tool=tool)
    return {"tool": tool, "quantities": [_law_json(law) for law in laws]}


def _law_json(law: FleetLaw) -> dict[str, Any]:
    p = law.provenance
    return {
        "quantity": law.quantity,
        "K": law.K,
        "catalogue_K": law.catalogue_K,
        "parameters": [asdict(parameter) for parameter in law.parameters],
        "reference": law.reference,
        "law_sd": law.law_sd,
        "new_machine_sd": law.new_machine_sd,
        "catalogue_sd": law.catalogue_sd,
        "between_machine_spread": p.spread,
        "operation_spread": p.operation_spread,
        "plans": len(p.plans),
        "machines": len(p.machines),
        "readings": p.readings,
        "text": p.describe(),
    }


def _known(session: Session, tool: str) -> None:
    """NotFoundError unless ``tool`` is stored, in the packaged catalogue, or imported.

    Imported: another database's own tool whose learned models ``rcb models import`` stored
    here (``imported_models``, by ``ix_imported_models_tool``): its machines are listed and
    taken out by name before any plan here uses it.
    """
    if tool in catalogue():
        return
    if session.scalar(select(t.Tool.id).where(t.Tool.name == tool)) is not None:
        return
    m = t.ImportedModel
    if session.scalar(select(m.id).where(m.tool == tool).limit(1)) is None:
        raise NotFoundError("tool", tool)
