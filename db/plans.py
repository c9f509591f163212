"""Plans, their replans and their setpoint versions: domain objects in and out of the tables.

Keyword-only functions given a session; the caller owns the transaction (one use case, one
transaction: :mod:`api.services.transactions`). A plan's RCB state is :mod:`db.state`, a part's
record :mod:`db.parts`.
"""

from __future__ import annotations

import uuid
from collections.abc import Mapping
from typing import Any

from sqlalchemy import func, insert, select
from sqlalchemy.orm import Session

from db import tables as t
from db.errors import ConflictError, PlanNameTakenError
from db.fleet import restarted_json
from db.fleet_changes import clear_fleet_change
from db.intake import PlanHead
from db.library import ensure_tool, load_tools
from db.model_versions import model_version_row, version_numbers
from db.plan_state import settings_json, settings_shown
from db.state_cache import CACHE, database_key
from models.powerlaw import Prediction
from models.tool import Tool
from supervisor.inputs.plan import Plan
from supervisor.optimize.extras import extras_of, with_extras
from supervisor.optimize.result import OperationResult, PlanResult
from supervisor.rcb.state import RcbSettings, RcbState

#: A plan's row as the ORM loads it, or the head of it a part report locks (db.intake).
PlanRow = t.Plan | PlanHead


def add_plan(
    *,
    session: Session,
    body: Mapping[str, Any],
    plan: Plan,
    result: PlanResult,
    settings: RcbSettings,
    prior: dict[str, Any] | None = None,
    noise_prior: dict[str, Any] | None = None,
) -> int:
    """Store a plan of a new name, its machine, tools (if new), version 1 and its priors."""
    refuse_taken(session, plan.name)  # a name names one plan
    machine = _machine(session, plan)
    plan_row = t.Plan(
        name=plan.name,
        machine_id=machine.id,
        body=dict(body),
        settings=settings_json(settings),
        prior=prior,
        noise_prior=noise_prior,
        current_setpoint_version=1,
        state_token=new_token(),
    )
    session.add(plan_row)
    session.flush()
    ids = _add_operations(session, plan, plan_row.id, machine.id)
    session.execute(
        insert(t.OperationModelVersion),
        [
            model_version_row(ids[op.name], model, 1, "initial", None)
            for op in plan.operations
            for model in plan.tools[op.tool].models.values()
        ],
    )
    add_setpoints(
        session=session,
        plan_id=plan_row.id,
        operations=ids,
        result=result,
        version=1,
        cause="initial",
        part_id=None,
    )
    return plan_row.id


def _add_operations(session: Session, plan: Plan, plan_id: int, machine_id: int) -> dict[str, int]:
    """Store the plan's operations (their tools if new); the id of each by name."""
    ops: dict[str, t.Operation] = {}
    for position, op in enumerate(plan.operations):
        tool = ensure_tool(session=session, tool=plan.tools[op.tool])
        ops[op.name] = t.Operation(
            plan_id=plan_id,
            machine_id=machine_id,
            position=position,
            name=op.name,
            process=op.process,
            tool_id=tool.id,
            volume_mm3=op.volume_mm3,
            limits=dict(op.limits),
            bounds={k: list(v) for k, v in op.bounds.items()},
            context=dict(op.context),
        )
    session.add_all(ops.values())
    session.flush()
    return {name: row.id for name, row in ops.items()}


def new_token() -> str:
    """A fresh ``plans.state_token``."""
    return uuid.uuid4().hex


def refuse_taken(session: Session, name: str) -> None:
    """Refuse a name a stored plan has (:class:`db.errors.PlanNameTakenError`).

    Checked before a new plan's prior is computed, and again as it is stored; two creates
    racing, the unique index refuses the second (a retry finds the first).
    """
    taken = plan_id_by_name(session=session, name=name)
    if taken is not None:
        raise PlanNameTakenError(name, taken)


def plan_id_by_name(*, session: Session, name: str) -> int | None:
    """The id of the plan named ``name``, None if there is none (names are unique)."""
    return session.scalars(select(t.Plan.id).where(t.Plan.name == name)).one_or_none()


def get_plan_row(*, session: Session, plan_id: int, lock: bool = False) -> t.Plan | None:
    """The plan row; ``lock`` takes a row lock (PostgreSQL) so reports of a plan serialise."""
    query = select(t.Plan).where(t.Plan.id == plan_id)
    if lock:
        query = query.with_for_update()
    return session.scalars(query).one_or_none()


def current_body(*, session: Session, plan_row: PlanRow) -> dict[str, Any]:
    """The plan structure in force: the newest replan's, else the one the plan was created with."""
    revision = _latest_revision(session, plan_row.id)
    if revision is not None:
        return dict(revision.body)
    if isinstance(plan_row, t.Plan):
        return dict(plan_row.body)
    return dict(session.scalars(select(t.Plan.body).where(t.Plan.id == plan_row.id)).one())


def _latest_revision(session: Session, plan_id: int) -> t.PlanRevision | None:
    return session.scalars(
        select(t.PlanRevision)
        .where(t.PlanRevision.plan_id == plan_id)
        .order_by(t.PlanRevision.setpoint_version.desc())
        .limit(1)
    ).one_or_none()


def add_replan(
    *,
    session: Session,
    plan_row: t.Plan,
    body: Mapping[str, Any],
    changes: Mapping[str, Any],
    reset_bands: bool,
    before: RcbState,
    after: RcbState,
    actor: str,
) -> None:
    """Store a replan: revision, changed models (cause ``replan``), setpoints, settings."""
    rows = operation_rows(session=session, plan_id=plan_row.id)
    ops = {name: row.id for name, row in rows.items()}
    last_part = session.scalar(select(func.max(t.Part.id)).where(t.Part.plan_id == plan_row.id))
    session.add(
        t.PlanRevision(
            plan_id=plan_row.id,
            setpoint_version=after.version,
            body=dict(body),
            changes=dict(changes),
            reset_bands=reset_bands,
            bands_reset_after_part=int(last_part or 0) if reset_bands else None,
            actor=actor,
        )
    )
    versions = version_numbers(session=session, plan_id=plan_row.id)
    changed = [
        model_version_row(ops[name], model, versions[(ops[name], q)] + 1, "replan", None)
        for name, tool in after.tools.items()
        for q, model in tool.models.items()
        if before.tools[name].models.get(q) != model
    ]
    if changed:
        session.execute(insert(t.OperationModelVersion), changed)
    add_setpoints(
        session=session,
        plan_id=plan_row.id,
        operations=ops,
        result=after.setpoints,
        version=after.version,
        cause="replan",
        part_id=None,
    )
    plan_row.current_setpoint_version = after.version
    plan_row.halt = None  # a replan resumes a halted plan
    if reset_bands:  # the monitors start again: so does the count of changes (db.fleet)
        plan_row.fleet_changes_accepted = 0
        clear_fleet_change(plan_row)
    prior = restarted_json(plan_row.prior, after.priors)
    if prior is not None:  # reset bands: a fleet prior the machine let go stays let go
        plan_row.prior = prior
    settings = settings_json(after.settings)
    if settings != settings_shown(plan_row.settings):  # rcb replan --rcb NAME=VALUE
        plan_row.settings = settings  # (against the stored: before's may hold a repair's)
    plan_row.state_token = new_token()
    session.flush()


def plan_tools(*, session: Session, plan_id: int) -> dict[str, Tool]:
    """The stored tools a plan's operations use (its body may name tools added over REST)."""
    names = select(t.Tool.name).join(t.Operation, t.Operation.tool_id == t.Tool.id)
    return load_tools(
        session=session, names=session.scalars(names.where(t.Operation.plan_id == plan_id))
    )


def operation_ids(*, session: Session, plan_row: PlanRow) -> dict[str, int]:
    """A plan's operation ids by name (cached with its state, under ``plan_row.state_token``)."""
    database = database_key(session)
    cached = CACHE.get_operations(database, plan_row.id, plan_row.state_token)
    if cached is not None:
        return cached
    rows = operation_rows(session=session, plan_id=plan_row.id)
    ops = {name: row.id for name, row in rows.items()}
    CACHE.put_operations(database, plan_row.id, plan_row.state_token, ops)
    return ops


def operation_rows(*, session: Session, plan_id: int) -> dict[str, t.Operation]:
    """A plan's operation rows by name (uncached)."""
    rows = session.scalars(select(t.Operation).where(t.Operation.plan_id == plan_id))
    return {row.name: row for row in rows}


def _machine(session: Session, plan: Plan) -> t.Machine:
    m = plan.machine
    limits = {name: float(value) for name, value in m.limits().items()}
    row = session.scalars(select(t.Machine).where(t.Machine.name == m.name)).one_or_none()
    if row is None:
        row = t.Machine(name=m.name, limits=limits)
        session.add(row)
        session.flush()
    elif row.limits != limits:
        raise ConflictError("machine.name", m.name, "a machine of this name has other limits")
    return row


def setpoints_of(*, session: Session, plan_row: PlanRow, version: int) -> PlanResult:
    """The stored setpoints of one version of a plan."""
    version_row = session.scalars(
        select(t.SetpointVersion).where(
            t.SetpointVersion.plan_id == plan_row.id, t.SetpointVersion.version == version
        )
    ).one()
    rows = session.execute(
        select(t.Setpoint, t.Operation, t.Tool)
        .join(t.Operation, t.Setpoint.operation_id == t.Operation.id)
        .join(t.Tool, t.Operation.tool_id == t.Tool.id)
        .where(t.Setpoint.setpoint_version_id == version_row.id)
        .order_by(t.Operation.position)
    ).all()
    machine = session.get(t.Machine, plan_row.machine_id)
    results = tuple(
        with_extras(
            OperationResult(
                name=op.name,
                tool=tool.name,
                process=op.process,  # type: ignore[arg-type]
                setpoint=dict(sp.parameters),
                predicted={q: Prediction(p["value"], p["band"]) for q, p in sp.predicted.items()},
                mrr_cm3_min=sp.mrr_cm3_min,
                time_min=sp.time_min,
                binding=tuple(sp.binding),
            ),
            sp.extras,
        )
        for sp, op, tool in rows
    )
    return PlanResult(plan_row.name, machine.name if machine else "", results)


def add_setpoints(
    *,
    session: Session,
    plan_id: int,
    operations: Mapping[str, int],
    result: PlanResult,
    version: int,
    cause: str,
    part_id: int | None,
) -> None:
    """Store ``result`` as setpoint version ``version`` of a plan (``operations``: ids by name).

    ``cause``: ``initial``, ``part`` (with ``part_id``) or ``replan``.
    """
    version_row = t.SetpointVersion(plan_id=plan_id, version=version, cause=cause, part_id=part_id)
    session.add(version_row)
    session.flush()
    session.execute(
        insert(t.Setpoint),
        [
            {
                "setpoint_version_id": version_row.id,
                "operation_id": operations[op.name],
                "parameters": dict(op.setpoint),
                "predicted": {
                    q: {"value": p.value, "band": p.band} for q, p in op.predicted.items()
                },
                "binding": list(op.binding),
                "mrr_cm3_min": op.mrr_cm3_min,
                "time_min": op.time_min,
                "extras": extras_of(op),
            }
            for op in result.operations
        ],
    )
