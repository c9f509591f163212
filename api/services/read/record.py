"""What a plan's report shows, read in a bounded number of statements and rows.

``rcb report`` and the web view's plan page show the last ``last`` parts (plots and marks),
the newest :data:`HISTORY_ROWS` setpoint versions one by one and older ones summarised per
:data:`SUMMARY_GROUP` versions, and the plan's totals. :func:`report_record` reads exactly
that: the totals and the summaries are SQL aggregates (:mod:`db.read.record`), so the statements
are the same and the rows grow with ``last`` and the summary rows, not with the plan's life.
"""

from __future__ import annotations

import math
from typing import Any

from sqlalchemy import Engine
from sqlalchemy.orm import Session

from api.services import request_limits
from api.services.read.common import _read
from api.services.read.plan_parts import decision_json, part_json
from api.services.read.plans import get_plan
from db import tables as t
from db.read import record as db_record
from db.read.parts import parts_page
from db.read.plans import operations
from db.table_base import as_utc
from models.errors import InputError

#: The measurement that carries a reported feed override and the tool change it called for.
TOOL_CHANGE = "feed_override_percent"
#: Parts plotted and listed unless asked otherwise (``rcb report --last``).
DEFAULT_LAST = request_limits.REPORT_DEFAULT_LAST
#: Most parts a report may plot (``--last``).
MAX_LAST = request_limits.REPORT_MAX_LAST
#: Setpoint versions listed one by one (the newest); older ones are summarised.
HISTORY_ROWS = 200
#: Older setpoint versions per summary row, while there are at most :data:`SUMMARY_ROWS` rows.
SUMMARY_GROUP = 100
#: Most summary rows: beyond ``SUMMARY_ROWS * SUMMARY_GROUP`` older versions a row covers more.
SUMMARY_ROWS = 50


def group_size(older: int) -> int:
    """Versions per summary row for ``older`` versions: 100, or a multiple of 100 beyond 5000."""
    rows = max(1, math.ceil(older / (SUMMARY_GROUP * SUMMARY_ROWS)))
    return SUMMARY_GROUP * rows


def report_record(*, engine: Engine, plan_id: int, last: int = DEFAULT_LAST) -> dict[str, Any]:
    """The plan, its last ``last`` parts and the setpoint versions and totals the page shows.

    Returns
    -------
    dict
        ``plan`` (:func:`api.services.read.plans.get_plan`), ``history`` (``versions``: the newest
        :data:`HISTORY_ROWS`, those the parts were made with, version 1 and the summaries' first and
        last, oldest first), ``parts`` (the last ``last``, oldest first, as
        :func:`api.services.read.plan_parts.parts` items), ``totals`` (parts, last received,
        flagged, breaches, notes, the first cycle time), ``summaries`` (per group of older
        versions), ``last_decisions`` (per operation and quantity the newest decision with its
        part's serial) and ``marks`` (part id -> flagged or noted decisions of the listed versions).
    """
    if not 1 <= last <= MAX_LAST:
        raise InputError("--last", last, f"must be between 1 and {MAX_LAST}")
    plan = get_plan(engine=engine, plan_id=plan_id)  # NotFoundError if none
    with _read(engine) as session, session.begin():
        ops = operations(session=session, plan_id=plan_id)
        names = {op.id: op.name for op, _ in ops}
        parts, measurements, decisions, _ = parts_page(
            session=session, plan_id=plan_id, after_id=0, limit=last, newest=True
        )
        count, received = db_record.part_totals(session=session, plan_id=plan_id)
        totals = db_record.decision_totals(session=session, plan_id=plan_id)
        cut, groups = _older_groups(session, plan_id)
        wanted = {1, *(p.setpoint_version for p in parts), *db_record.summary_of(groups)}
        versions = db_record.versions(
            session=session, plan_id=plan_id, newer_than=cut, numbers=wanted
        )
        listed = [v.part_id for v, _, _ in versions if v.version > cut and v.part_id is not None]
        marks = db_record.marked_decisions(session=session, part_ids=listed)
        latest = db_record.last_decisions(session=session, plan_id=plan_id)
    by_number = {
        v.version: _version(v, serial, setpoints, ops) for v, serial, setpoints in versions
    }
    return {
        "plan": plan,
        "history": {
            "plan_id": plan_id,
            "status": plan["status"],
            "halt": plan["halt"],
            "versions": [by_number[n] for n in sorted(by_number)],
        },
        "parts": [part_json(p, measurements[p.id], decisions[p.id], names) for p in parts],
        "totals": {
            "parts": count,
            "last_received": as_utc(received) if received is not None else None,
            **totals,
            "first_cycle_time_min": by_number[min(by_number)]["cycle_time_min"],
        },
        "summaries": [_summary(by_number[first], by_number[end], n) for first, end, n in groups],
        "last_decisions": [{**decision_json(d, names), "serial": serial} for d, serial in latest],
        "marks": {part: [decision_json(d, names) for d in rows] for part, rows in marks.items()},
    }


def _older_groups(session: Session, plan_id: int) -> tuple[int, list[tuple[int, int, int]]]:
    """The last version summarised (0: none) and the groups of versions up to it."""
    newest = session.get_one(t.Plan, plan_id).current_setpoint_version
    cut = max(0, newest - HISTORY_ROWS)
    if not cut:
        return 0, []
    return cut, db_record.version_groups(
        session=session, plan_id=plan_id, up_to=cut, size=group_size(cut)
    )


def _summary(first: dict[str, Any], last: dict[str, Any], count: int) -> dict[str, Any]:
    """A group of older versions: its first and last version (as listed) and how many."""
    return {"first": first, "last": last, "versions": count}


def _version(
    version: t.SetpointVersion,
    serial: str | None,
    setpoints: list[t.Setpoint],
    ops: list[tuple[t.Operation, t.Tool]],
) -> dict[str, Any]:
    """A setpoint version as :func:`api.services.read.history.plan_history` gives it, no models."""
    position = {op.id: i for i, (op, _) in enumerate(ops)}
    names = {op.id: op.name for op, _ in ops}
    tools = {op.id: tool.name for op, tool in ops}
    in_order = sorted(setpoints, key=lambda s: position[s.operation_id])
    return {
        "version": version.version,
        "cause": version.cause,
        "part_id": version.part_id,
        "serial": serial,
        "created_at": as_utc(version.created_at),
        "cycle_time_min": sum(sp.time_min for sp in in_order),  # plan order (history.py)
        "operations": [
            {
                "name": names[sp.operation_id],
                "tool": tools[sp.operation_id],
                "setpoint": dict(sp.parameters),
                "predicted": dict(sp.predicted),
                "mrr_cm3_min": sp.mrr_cm3_min,
                "time_min": sp.time_min,
                "binding": list(sp.binding),
                "extras": dict(sp.extras or {}),
            }
            for sp in in_order
        ],
    }
