"""A plan's setpoint history, a page at a time, with the models in force at each version.

One read transaction per page; the cost grows with the page, not with the plan's life
(:func:`db.read.history.models_at`).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

from sqlalchemy import Engine

from api.services.read.common import MAX_PAGE, _bounded, _plan, _read, ordered_cursor, ordered_value
from api.services.writes_first import GATE
from db import tables as t
from db.read import history
from db.read.plans import operations
from db.table_base import as_utc

#: Versions converted between two pauses for writes in flight (api.services.writes_first).
PAUSE_EVERY = 10
#: Setpoint versions on a history page unless asked otherwise.
HISTORY_PAGE = 100


def plan_history(
    *,
    engine: Engine,
    plan_id: int,
    cursor: str | None = None,
    page_size: int = HISTORY_PAGE,
    newest: bool = False,
) -> dict[str, Any]:
    """A page of setpoint versions with cause, setpoints and the models (bands) in force.

    Versions come oldest first. ``newest``: the newest ``page_size`` versions before ``cursor``
    (REST ``order=newest``), ``next_cursor`` (``"n41"``) pages back; else ``next_cursor``
    (``"41"``) pages forward (:func:`api.services.read.common.ordered_cursor`). The cost is
    linear in the page, not in the history (:func:`db.read.history.models_at`).
    """
    _bounded(page_size)
    mark = ordered_value(cursor, newest=newest)
    GATE.pause()  # the read transaction starts when no part report is in flight
    with _read(engine) as session, session.begin():
        halt = _plan(session, plan_id).halt
        ops = operations(session=session, plan_id=plan_id)
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
        actors = history.revision_actors(
            session=session, plan_id=plan_id, versions=[v.version for v, *_ in versions]
        )
    out = []
    for n, (v, serial, setpoints) in enumerate(versions):
        if n % PAUSE_EVERY == 0:
            GATE.pause()  # a part report in flight goes first (api.services.writes_first)
        out.append(_history_version(v, serial, setpoints, ops, models[v.id], actors.get(v.version)))
    edge = (versions[0] if newest else versions[-1])[0].version if versions else 0
    status = "halted" if halt is not None else "running"
    return {
        "plan_id": plan_id,
        "status": status,
        "halt": halt,
        "versions": out,
        "next_cursor": ordered_cursor(edge, newest=newest) if more else None,
    }


def history_pages(*, engine: Engine, plan_id: int) -> Iterator[dict[str, Any]]:
    """A plan's history page by page (:func:`plan_history`), oldest first: one in memory."""
    cursor = None
    while True:
        page = plan_history(engine=engine, plan_id=plan_id, cursor=cursor, page_size=MAX_PAGE)
        yield page
        cursor = page["next_cursor"]
        if cursor is None:
            return


def full_history(*, engine: Engine, plan_id: int) -> dict[str, Any]:
    """Every setpoint version in one answer (:func:`history_pages`), the last page's status.

    Memory grows with the plan's life: ``rcb export`` reads :func:`history_pages` instead.
    """
    versions: list[dict[str, Any]] = []
    for page in history_pages(engine=engine, plan_id=plan_id):
        versions += page["versions"]
    return {**page, "versions": versions}


def _history_version(
    version: t.SetpointVersion,
    serial: str | None,
    setpoints: list[t.Setpoint],
    ops: list[tuple[t.Operation, t.Tool]],
    in_force: dict[tuple[int, str], t.OperationModelVersion],
    actor: str | None,
) -> dict[str, Any]:
    """One setpoint version as JSON, operations in plan order with their models in force.

    ``actor``: who made it, for a replan (``key:ID`` or ``cli:NAME``); None otherwise.
    """
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
        "actor": actor,
        "part_id": version.part_id,
        "serial": serial,
        "created_at": as_utc(version.created_at),
        # in plan order, as the optimiser sums it: the rows' order is the database's whim, and
        # another order may round the last bit otherwise (PostgreSQL against SQLite)
        "cycle_time_min": sum(op["time_min"] for op in operations),
        "operations": operations,
    }
