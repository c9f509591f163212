"""Use cases that only read: plans, setpoints, parts, history, models and tools, as JSON dicts.

Each runs in one read transaction (on SQLite a deferred one, so it never waits for writers).
"""

from __future__ import annotations

import re
from datetime import UTC, datetime
from typing import Any

from sqlalchemy import Engine
from sqlalchemy.orm import Session

from api.services import to_json
from api.services.errors import NotFoundError, PlanHaltedError
from db import history, library
from db import tables as t
from db.engine import reader
from db.parts import count_parts
from db.plans import current_body, get_plan_row, setpoints_of
from models.catalogue import catalogue
from models.errors import InputError

#: Most parts (or setpoint versions) one page may hold.
MAX_PAGE = 500
#: Setpoint versions on a history page unless asked otherwise.
HISTORY_PAGE = 100


def list_plans(*, engine: Engine) -> dict[str, Any]:
    """Every plan with its machine, current setpoint version and part count."""
    with _read(engine) as session, session.begin():
        return {"plans": history.plans(session=session)}


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
                "max_power_kW": machine.max_power_kW if machine else None,
                "max_spindle_rpm": machine.max_spindle_rpm if machine else None,
                "max_torque_Nm": machine.max_torque_Nm if machine else None,
                "max_feed_rate_mm_min": machine.max_feed_rate_mm_min if machine else None,
            },
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
        "operations": to_json.plan_json(result)["operations"],
    }


def parts(
    *, engine: Engine, plan_id: int, cursor: str | None = None, page_size: int = 50
) -> dict[str, Any]:
    """A page of a plan's parts, oldest first; ``next_cursor`` continues after the last.

    ``page_size``: most parts on the page (the REST query parameter ``limit``).
    """
    if not 1 <= page_size <= MAX_PAGE:
        raise InputError("limit", page_size, f"must be between 1 and {MAX_PAGE}")
    after = _cursor(cursor)
    with _read(engine) as session, session.begin():
        _plan(session, plan_id)
        names = {op.id: op.name for op, _ in history.operations(session=session, plan_id=plan_id)}
        rows, measurements, decisions = history.parts_page(
            session=session, plan_id=plan_id, after_id=after, limit=page_size
        )
        items = []
        for part in rows:
            per_op: dict[str, dict[str, Any]] = {}
            for m in measurements[part.id]:
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
            items.append(
                {
                    "part_id": part.id,
                    "serial": part.serial,
                    "setpoint_version": part.setpoint_version,
                    "received_at": _utc(part.received_at),
                    "operations": [{"name": name, **entry} for name, entry in per_op.items()],
                    "updates": [_decision(d, names) for d in decisions[part.id]],
                }
            )
    more = len(rows) == page_size
    return {"items": items, "next_cursor": str(rows[-1].id) if rows and more else None}


def all_parts(*, engine: Engine, plan_id: int) -> list[dict[str, Any]]:
    """Every part of a plan, oldest first (:func:`parts`, page after page)."""
    items: list[dict[str, Any]] = []
    cursor = None
    while True:
        page = parts(engine=engine, plan_id=plan_id, cursor=cursor, page_size=MAX_PAGE)
        items += page["items"]
        cursor = page["next_cursor"]
        if cursor is None:
            return items


def record(
    *, engine: Engine, plan_id: int
) -> tuple[dict[str, Any], dict[str, Any], list[dict[str, Any]]]:
    """A plan, every part and the setpoint history: what a report shows.

    Parts are read before the history, so every version a part names is in the history.
    """
    plan = get_plan(engine=engine, plan_id=plan_id)
    items = all_parts(engine=engine, plan_id=plan_id)
    return plan, full_history(engine=engine, plan_id=plan_id), items


def plan_history(
    *,
    engine: Engine,
    plan_id: int,
    cursor: str | None = None,
    page_size: int = HISTORY_PAGE,
    newest: bool = False,
) -> dict[str, Any]:
    """A page of setpoint versions with cause, setpoints and the models (bands) in force.

    Versions come oldest first. ``newest``: the page is the newest ``page_size`` versions
    before ``cursor`` (the REST ``order=newest``); ``next_cursor`` then pages back in time.
    Otherwise the page follows ``cursor`` and ``next_cursor`` pages forward. The cost is
    linear in the page, not in the plan's history (:func:`db.history.models_at`).
    """
    if not 1 <= page_size <= MAX_PAGE:
        raise InputError("limit", page_size, f"must be between 1 and {MAX_PAGE}")
    mark = _cursor(cursor)
    with _read(engine) as session, session.begin():
        halt = _plan(session, plan_id).halt
        ops = history.operations(session=session, plan_id=plan_id)
        # one more than the page: whether another page follows
        if newest:
            versions = history.setpoint_versions(
                session=session,
                plan_id=plan_id,
                before=mark or None,
                limit=page_size + 1,
                newest=True,
            )
        else:
            versions = history.setpoint_versions(
                session=session, plan_id=plan_id, after=mark, limit=page_size + 1
            )
        more = len(versions) > page_size
        if more:
            versions = versions[1:] if newest else versions[:-1]
        models = history.models_at(
            session=session,
            operation_ids=[op.id for op, _ in ops],
            versions=[v for v, *_ in versions],
        )
    out = [
        _history_version(v, serial, setpoints, ops, models[v.id])
        for v, serial, setpoints in versions
    ]
    edge = (versions[0] if newest else versions[-1])[0].version if versions else 0
    status = "halted" if halt is not None else "running"
    return {
        "plan_id": plan_id,
        "status": status,
        "halt": halt,
        "versions": out,
        "next_cursor": str(edge) if more else None,
    }


def full_history(*, engine: Engine, plan_id: int) -> dict[str, Any]:
    """Every setpoint version (:func:`plan_history`, page after page); for exports."""
    page = plan_history(engine=engine, plan_id=plan_id, page_size=MAX_PAGE)
    versions = page["versions"]
    while page["next_cursor"] is not None:
        page = plan_history(
            engine=engine, plan_id=plan_id, cursor=page["next_cursor"], page_size=MAX_PAGE
        )
        versions += page["versions"]
    return {**page, "versions": versions, "next_cursor": None}


def _history_version(
    version: t.SetpointVersion,
    serial: str | None,
    setpoints: list[t.Setpoint],
    ops: list[tuple[t.Operation, t.Tool]],
    in_force: dict[tuple[int, str], t.OperationModelVersion],
) -> dict[str, Any]:
    """One setpoint version as JSON, operations in plan order with their models in force."""
    position = {op.id: i for i, (op, _) in enumerate(ops)}
    names = {op.id: op.name for op, _ in ops}
    tools = {op.id: tool.name for op, tool in ops}
    models: dict[int, dict[str, Any]] = {}
    for (operation_id, quantity), model in sorted(in_force.items()):
        models.setdefault(operation_id, {})[quantity] = {
            "K": model.K,
            "dK": model.dK,
            "version": model.version,
        }
    operations = [
        {
            "name": names[sp.operation_id],
            "tool": tools[sp.operation_id],
            "setpoint": dict(sp.parameters),
            "predicted": dict(sp.predicted),
            "mrr_cm3_min": sp.mrr_cm3_min,
            "time_min": sp.time_min,
            "binding": list(sp.binding),
            "models": models.get(sp.operation_id, {}),
        }
        for sp in sorted(setpoints, key=lambda s: position[s.operation_id])
    ]
    return {
        "version": version.version,
        "cause": version.cause,
        "part_id": version.part_id,
        "serial": serial,
        "created_at": _utc(version.created_at),
        "cycle_time_min": sum(sp.time_min for sp in setpoints),
        "operations": operations,
    }


def models_in_force(*, engine: Engine, plan_id: int) -> dict[str, Any]:
    """Per operation and quantity the newest model version: K, ΔK, exponents, version, cause."""
    with _read(engine) as session, session.begin():
        _plan(session, plan_id)
        ops = history.operations(session=session, plan_id=plan_id)
        rows = history.model_versions(session=session, plan_id=plan_id)
    latest: dict[str, dict[str, Any]] = {}
    for model, op_name, serial in rows:
        latest.setdefault(op_name, {})[model.quantity] = _model_version(model, serial)
    return {
        "plan_id": plan_id,
        "operations": [
            {"name": op.name, "tool": tool.name, "models": latest.get(op.name, {})}
            for op, tool in ops
        ],
    }


def model_versions(
    *, engine: Engine, plan_id: int, operation: str | None = None, quantity: str | None = None
) -> dict[str, Any]:
    """Every model version of the plan, optionally of one operation and/or quantity."""
    with _read(engine) as session, session.begin():
        _plan(session, plan_id)
        ops = history.operations(session=session, plan_id=plan_id)
        if operation is not None and operation not in {op.name for op, _ in ops}:
            raise NotFoundError("operation", operation)
        rows = history.model_versions(
            session=session, plan_id=plan_id, operation=operation, quantity=quantity
        )
    return {
        "plan_id": plan_id,
        "versions": [
            {"operation": name, "quantity": m.quantity, **_model_version(m, serial)}
            for m, name, serial in rows
        ],
    }


def list_tools(*, engine: Engine) -> dict[str, Any]:
    """The packaged catalogue and the tools stored in the database, by name."""
    with _read(engine) as session, session.begin():
        stored = library.load_tools(session=session)
    tools = {**catalogue(), **stored}
    return {"tools": [to_json.tool_json(tools[name]) for name in sorted(tools)]}


def get_tool(*, engine: Engine, name: str) -> dict[str, Any]:
    """One tool with its baseline models and provenance."""
    with _read(engine) as session, session.begin():
        stored = library.load_tools(session=session, names=[name])
    tool = stored.get(name) or catalogue().get(name)
    if tool is None:
        raise NotFoundError("name", name)
    return to_json.tool_json(tool)


def _model_version(model: t.OperationModelVersion, serial: str | None) -> dict[str, Any]:
    return {
        "version": model.version,
        "K": model.K,
        "dK": model.dK,
        "exponents": dict(model.exponents),
        "cause": model.cause,
        "serial": serial,
        "created_at": _utc(model.created_at),
    }


def _decision(d: t.RcbDecision, names: dict[int, str]) -> dict[str, Any]:
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


def _read(engine: Engine) -> Session:
    # rows are read after the transaction ends: keep their loaded attributes
    return Session(reader(engine), expire_on_commit=False)


def _utc(moment: datetime) -> datetime:
    # SQLite returns naive datetimes; they were stored as UTC (db.tables.utcnow)
    return moment if moment.tzinfo else moment.replace(tzinfo=UTC)


def _cursor(cursor: str | None) -> int:
    if cursor is None:
        return 0
    if re.fullmatch(r"[0-9]{1,10}", cursor) is None or int(cursor) > 2**31 - 1:
        raise InputError("cursor", cursor, "not a cursor returned by this endpoint")
    return int(cursor)


def _plan(session: Session, plan_id: int) -> t.Plan:
    row = get_plan_row(session=session, plan_id=plan_id)
    if row is None:
        raise NotFoundError("plan_id", plan_id)
    return row
