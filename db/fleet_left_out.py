"""What the fleet left out of a tool's plans, said where a new plan's prior is made (issue 32).

A prior "from 1 plan on 1 machine" reads as the fleet's whole word on the tool; where two
newer plans of it halted on readings past the band, it is not. So a new plan's provenance
counts the tool's plans the fleet left out, by their first reason (as ``rcb fleet show``
orders them): taken out by an engineer (the plan or its machine), halted, or its process
changed beyond what an engineer accepted (:mod:`db.fleet_members` says which and why).

Counted among each machine's newest plans with the tool that learned a model of it
(:func:`db.fleet_window.newest_local` with ``every``: halted and taken out ones too), so the
cost is bounded by the machines, not by the plans they made: two statements (the window with
each plan's settings, halt and exclusion; its changes summed, :func:`db.fleet_changes.
plan_changes`), the same for 10 plans as for 1000. Not counted: a plan whose
strategy learns nothing (it never was the fleet's), and the models other databases exported
(they were exported from plans in their fleet).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from sqlalchemy import exists, select
from sqlalchemy.orm import Session

from db import tables as t
from db.fleet_changes import plan_changes
from db.fleet_window import excluded, newest_local
from db.plan_state import settings_of
from models.errors import InputError
from supervisor.fleet.left_out import LeftOut


def left_out(*, session: Session, tool_names: Iterable[str]) -> dict[str, LeftOut]:
    """Per named tool, its plans the fleet left out (module docstring); none: not named."""
    names = sorted(set(tool_names))
    if not names:
        return {}
    every = newest_local(names, session.get_bind().dialect.name, every=True)
    # a row an operation: a plan once a tool (DISTINCT here, not over the JSON settings)
    window = select(every.c.plan_id, every.c.tool_id).distinct().subquery("left_window")
    rows = session.execute(
        select(
            t.Tool.name,
            t.Plan.id,
            t.Plan.settings,
            t.Plan.halt.is_not(None),
            exists().where(excluded),
            t.Plan.fleet_changes_accepted,
        )
        .select_from(window)
        .join(t.Tool, t.Tool.id == window.c.tool_id)
        .join(t.Plan, t.Plan.id == window.c.plan_id)
        .join(t.Machine, t.Machine.id == t.Plan.machine_id)
    ).all()
    changes = plan_changes(session=session, plan_ids={row[1] for row in rows})
    counts: dict[str, dict[str, int]] = {}
    for tool, plan_id, stored, halted, taken, accepted in rows:
        why = _first_reason(taken, halted, changes.get(plan_id, 0) > accepted)
        if why is None or not _learns(stored):
            continue
        tally = counts.setdefault(tool, {})
        tally[why] = tally.get(why, 0) + 1
    return {tool: LeftOut(**tally) for tool, tally in counts.items()}


def _first_reason(taken: bool, halted: bool, changed: bool) -> str | None:
    """The field of :class:`LeftOut` a plan counts in (None: in the fleet)."""
    if taken:
        return "taken_out"
    if halted:
        return "halted"
    return "changed" if changed else None


def _learns(stored: Mapping[str, Any] | None) -> bool:
    """Whether the plan's stored settings learn (a setting this version refuses: not counted)."""
    try:
        return settings_of(stored).strategy == "learn"
    except InputError:
        return False
