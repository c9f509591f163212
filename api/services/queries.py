"""Use cases that only read: plans, setpoints, parts, history, models and tools, as JSON dicts.

Each runs in one read transaction (on SQLite a deferred one, so it never waits for writers).
"""

from __future__ import annotations

from collections.abc import Iterator
from datetime import datetime
from typing import Any

from sqlalchemy import Engine

from api.services import to_json
from api.services.errors import NotFoundError, PlanHaltedError
from api.services.history import HISTORY_PAGE as HISTORY_PAGE
from api.services.history import full_history as full_history
from api.services.history import plan_history as plan_history
from api.services.lists import LIST_PAGE as LIST_PAGE
from api.services.lists import list_plans as list_plans
from api.services.lists import list_tools as list_tools
from api.services.lists import model_versions as model_versions
from api.services.lists import models_in_force as models_in_force
from api.services.reading import MAX_PAGE as MAX_PAGE
from api.services.reading import _cursor, _plan, _read, _utc
from db import history, library
from db import tables as t
from db.fleet import prior_answer
from db.parts import count_parts
from db.plans import current_body, setpoints_of
from models import quantities
from models.catalogue import catalogue
from models.errors import InputError


def get_plan(*, engine: Engine, plan_id: int) -> dict[str, Any]:
    """One plan: summary, machine limits, operations (limits, bounds, volume), the plan body."""
    with _read(engine) as session, session.begin():
        row = _plan(session, plan_id)
        machine = session.get(t.Machine, row.machine_id)
        ops = history.operations(session=session, plan_id=plan_id)
        parts = count_parts(session=session, plan_id=plan_id)
        body = current_body(session=session, plan_row=row)
        in_force = {o.get("name"): o for o in body.get("operations", [])}
        return {
            **history.summary(row, machine.name if machine else "", parts),
            "machine_limits": {
                key: machine.limits.get(name) if machine else None
                for key, name in quantities.machine_fields().items()
            },
            **prior_answer(row.prior),
            "operations": [
                {
                    "name": op.name,
                    "tool": tool.name,
                    "process": op.process,
                    "volume_mm3": op.volume_mm3,
                    # as in force: a replan may have changed them (plan_revisions)
                    "limits": dict(in_force.get(op.name, {}).get("limits", op.limits)),
                    "bounds": dict(in_force.get(op.name, {}).get("bounds", op.bounds)),
                    "context": dict(op.context),
                }
                for op, tool in ops
            ],
            "body": body,
        }


def current_setpoints(*, engine: Engine, plan_id: int) -> dict[str, Any]:
    """The setpoints in force; a halted plan has none (:class:`PlanHaltedError`)."""
    with _read(engine) as session, session.begin():
        row = _plan(session, plan_id)
        if row.halt is not None:
            raise PlanHaltedError(plan_id, row.halt)
        version = row.current_setpoint_version
        result = setpoints_of(session=session, plan_row=row, version=version)
    return {
        "plan_id": plan_id,
        "setpoint_version": version,
        **prior_answer(row.prior),
        "operations": to_json.plan_json(result)["operations"],
    }


def parts(
    *,
    engine: Engine,
    plan_id: int,
    cursor: str | None = None,
    page_size: int = 50,
    newest: bool = False,
    since: datetime | None = None,
) -> dict[str, Any]:
    """A page of a plan's parts, oldest first; ``next_cursor`` continues after the last.

    ``page_size``: most parts on the page (the REST query parameter ``limit``). ``newest``:
    the newest parts before ``cursor`` (``next_cursor`` then pages back in time). ``since``:
    only parts received at or after this time. Only the page's rows are read.
    """
    if not 1 <= page_size <= MAX_PAGE:
        raise InputError("limit", page_size, f"must be between 1 and {MAX_PAGE}")
    after = _cursor(cursor)
    with _read(engine) as session, session.begin():
        _plan(session, plan_id)
        names = {op.id: op.name for op, _ in history.operations(session=session, plan_id=plan_id)}
        rows, measurements, decisions = history.parts_page(
            session=session,
            plan_id=plan_id,
            after_id=after,
            limit=page_size,
            newest=newest,
            since=since,
        )
        items = [part_json(part, measurements[part.id], decisions[part.id], names) for part in rows]
    more = len(rows) == page_size
    edge = rows[0] if newest else rows[-1] if rows else None
    return {"items": items, "next_cursor": str(edge.id) if edge is not None and more else None}


def decisions(*, engine: Engine, plan_id: int, part_ids: list[int]) -> dict[int, list[Any]]:
    """The RCB decisions of these parts of a plan (``updates`` of :func:`parts`), per part id."""
    with _read(engine) as session, session.begin():
        names = {op.id: op.name for op, _ in history.operations(session=session, plan_id=plan_id)}
        found = history.decisions_of(session=session, part_ids=part_ids)
    return {part: [decision_json(d, names) for d in rows] for part, rows in found.items()}


def all_parts(*, engine: Engine, plan_id: int) -> list[dict[str, Any]]:
    """Every part of a plan, oldest first (:func:`parts`, page after page)."""
    return [item for page in part_pages(engine=engine, plan_id=plan_id) for item in page]


def part_pages(
    *, engine: Engine, plan_id: int, since: datetime | None = None
) -> Iterator[list[dict[str, Any]]]:
    """A plan's parts page by page, oldest first: one page in memory at a time."""
    cursor = None
    while True:
        page = parts(engine=engine, plan_id=plan_id, cursor=cursor, page_size=MAX_PAGE, since=since)
        if page["items"]:
            yield page["items"]
        cursor = page["next_cursor"]
        if cursor is None:
            return


def get_tool(*, engine: Engine, name: str) -> dict[str, Any]:
    """One tool with its baseline models and provenance."""
    with _read(engine) as session, session.begin():
        stored = library.load_tools(session=session, names=[name])
    tool = stored.get(name) or catalogue().get(name)
    if tool is None:
        raise NotFoundError("name", name)
    return to_json.tool_json(tool)


def part_json(
    part: t.Part,
    measurements: list[t.Measurement],
    decisions: list[t.RcbDecision],
    names: dict[int, str],
) -> dict[str, Any]:
    """A part as an item of :func:`parts`: its measurements per operation and its decisions."""
    per_op: dict[str, dict[str, Any]] = {}
    for m in measurements:
        entry = per_op.setdefault(names[m.operation_id], {"measurements": {}})
        if m.quantity == "flank_wear_mm":
            entry["tool_wear"] = {
                "flank_wear_mm": {"value": m.value, "uncertainty": m.uncertainty},
                "volume_mm3": (m.raw or {}).get("volume_mm3"),
            }
        else:
            entry["measurements"][m.quantity] = {
                "value": m.value,
                "uncertainty": m.uncertainty,
                **({"raw": m.raw} if m.raw else {}),
            }
    return {
        "part_id": part.id,
        "serial": part.serial,
        "setpoint_version": part.setpoint_version,
        "received_at": _utc(part.received_at),
        "operations": [{"name": name, **entry} for name, entry in per_op.items()],
        "updates": [decision_json(d, names) for d in decisions],
    }


def decision_json(d: t.RcbDecision, names: dict[int, str]) -> dict[str, Any]:
    """An RCB decision as in a part's ``updates``, its operation by name."""
    return {
        "operation": names[d.operation_id],
        "quantity": d.quantity,
        "action": d.action,
        "margin": d.margin,
        "band_before": d.band_before,
        "band_after": d.band_after,
        "flagged": d.flagged,
        "flag": d.flag,
        "note": d.note,
        "reason": d.reason,
    }
