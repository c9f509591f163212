"""Repository functions: domain objects in and out of the tables. Keyword-only, given a session.

The caller owns the transaction (one use case, one transaction: :mod:`api.services.commands`).
"""

from __future__ import annotations

import uuid
from collections.abc import Mapping, Sequence
from typing import Any

from sqlalchemy import func, insert, select
from sqlalchemy.orm import Session

from db import tables as t
from db.bulk import defer
from db.errors import ConflictError
from db.intake import PlanHead
from db.library import ensure_tool, load_tools
from db.plan_state import halt_json, halt_of, settings_json, settings_of
from db.state_cache import CACHE
from models.powerlaw import PowerLawModel, Prediction
from models.tool import Tool
from supervisor.constant_load.setpoint import ToolChange
from supervisor.inputs.part_report import PartReport
from supervisor.inputs.plan import Plan, plan_from_mapping
from supervisor.optimize.extras import extras_of, with_extras
from supervisor.optimize.result import OperationResult, PlanResult
from supervisor.rcb.posterior import Posterior
from supervisor.rcb.posterior import from_json as posterior_from_json
from supervisor.rcb.state import Decision, RcbSettings, RcbState, prior_sigma

#: A plan's row as the ORM loads it, or the head of it a part report locks (db.intake).
PlanRow = t.Plan | PlanHead


def add_plan(
    *,
    session: Session,
    body: Mapping[str, Any],
    plan: Plan,
    result: PlanResult,
    settings: RcbSettings,
) -> int:
    """Store a plan, its machine and tools (if new), version 1 of its models and setpoints."""
    machine = _machine(session, plan)
    plan_row = t.Plan(
        name=plan.name,
        machine_id=machine.id,
        body=dict(body),
        strategy=settings.strategy,
        alpha=settings.alpha,
        settings=settings_json(settings),
        current_setpoint_version=1,
        state_token=new_token(),
    )
    session.add(plan_row)
    session.flush()
    ops: dict[str, t.Operation] = {}
    for position, op in enumerate(plan.operations):
        tool = ensure_tool(session=session, tool=plan.tools[op.tool])
        row = t.Operation(
            plan_id=plan_row.id,
            position=position,
            name=op.name,
            process=op.process,
            tool_id=tool.id,
            volume_mm3=op.volume_mm3,
            limits=dict(op.limits),
            bounds={k: list(v) for k, v in op.bounds.items()},
            context=dict(op.context),
        )
        session.add(row)
        ops[op.name] = row
    session.flush()
    ids = {name: row.id for name, row in ops.items()}
    session.execute(
        insert(t.OperationModelVersion),
        [
            _model_version_row(ids[op.name], model, 1, "initial", None)
            for op in plan.operations
            for model in plan.tools[op.tool].models.values()
        ],
    )
    _add_setpoints(session, plan_row.id, ids, result, 1, "initial", None)
    return plan_row.id


def new_token() -> str:
    """A fresh ``plans.state_token``."""
    return uuid.uuid4().hex


def get_plan_row(*, session: Session, plan_id: int, lock: bool = False) -> t.Plan | None:
    """The plan row; ``lock`` takes a row lock (PostgreSQL) so reports of a plan serialise."""
    query = select(t.Plan).where(t.Plan.id == plan_id)
    if lock:
        query = query.with_for_update()
    return session.scalars(query).one_or_none()


def load_state(*, session: Session, plan_row: PlanRow) -> RcbState:
    """The RCB state of a plan as stored: models, band states and setpoints in force.

    Call it with the plan row locked (``get_plan_row(lock=True)``): the state is then the
    committed one of ``plan_row.state_token`` and is cached under it (:mod:`db.state_cache`).
    """
    database = database_key(session)
    cached = CACHE.get(database, plan_row.id, plan_row.state_token)
    if cached is not None:
        return cached
    state = _load_state(session, plan_row)
    CACHE.put(database, plan_row.id, plan_row.state_token, state)
    return state


def database_key(session: Session) -> str:
    """Which database a session talks to (the state cache's first key)."""
    return session.get_bind().engine.url.render_as_string(hide_password=True)


def _load_state(session: Session, plan_row: PlanRow) -> RcbState:
    ops = _operations(session, plan_row.id)
    body = current_body(session=session, plan_row=plan_row)
    plan = plan_from_mapping(body, plan_tools(session=session, plan_id=plan_row.id))
    tools: dict[str, Tool] = {}
    sigma: dict[tuple[str, str], float] = {}
    seen: dict[tuple[str, str], float] = {}
    beliefs: dict[tuple[str, str], Posterior] = {}
    settings = settings_of(plan_row.strategy, plan_row.alpha, plan_row.settings)
    latest_models = _latest_models(session, plan_row.id)
    band_states = _latest_band_states(
        session, plan_row.id, _bands_reset_after(session, plan_row.id)
    )
    for op in plan.operations:
        base = plan.tools[op.tool]
        models = {}
        for quantity, baseline in base.models.items():
            row = latest_models[(ops[op.name].id, quantity)]
            models[quantity] = PowerLawModel(
                quantity, row.K, row.dK, dict(row.exponents), baseline.source, baseline.reference
            )
            state = band_states.get((ops[op.name].id, quantity))
            if state is None:
                sigma[(op.name, quantity)] = prior_sigma(baseline, settings)
            else:
                sigma[(op.name, quantity)] = state.sigma
                seen[(op.name, quantity)] = state.seen
                if state.posterior is not None:
                    beliefs[(op.name, quantity)] = posterior_from_json(state.posterior)
        tools[op.name] = Tool(
            base.name, base.process, models, base.description, base.material, base.source
        )
    setpoints = setpoints_of(
        session=session, plan_row=plan_row, version=plan_row.current_setpoint_version
    )
    return RcbState(
        plan,
        tools,
        setpoints,
        plan_row.current_setpoint_version,
        settings,
        sigma,
        seen,
        beliefs,
        halt_of(plan_row.halt),
    )


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


def _bands_reset_after(session: Session, plan_id: int) -> int:
    last = session.scalar(
        select(func.max(t.PlanRevision.bands_reset_after_part)).where(
            t.PlanRevision.plan_id == plan_id, t.PlanRevision.reset_bands.is_(True)
        )
    )
    return int(last or 0)


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
    """Store a replan: the revision, the changed models (cause ``replan``), new setpoints."""
    ops = {name: row.id for name, row in _operations(session, plan_row.id).items()}
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
    versions = _model_version_numbers(session, plan_row.id)
    rows = [
        _model_version_row(ops[name], model, versions[(ops[name], q)] + 1, "replan", None)
        for name, tool in after.tools.items()
        for q, model in tool.models.items()
        if before.tools[name].models.get(q) != model
    ]
    if rows:
        session.execute(insert(t.OperationModelVersion), rows)
    _add_setpoints(session, plan_row.id, ops, after.setpoints, after.version, "replan", None)
    plan_row.current_setpoint_version = after.version
    plan_row.halt = None  # a replan resumes a halted plan
    plan_row.state_token = new_token()
    session.flush()


def plan_tools(*, session: Session, plan_id: int) -> dict[str, Tool]:
    """The stored tools a plan's operations use (its body may name tools added over REST)."""
    names = select(t.Tool.name).join(t.Operation, t.Operation.tool_id == t.Tool.id)
    return load_tools(
        session=session, names=session.scalars(names.where(t.Operation.plan_id == plan_id))
    )


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


def add_part(
    *,
    session: Session,
    plan_row: PlanHead,
    part_id: int,
    operations: Mapping[str, int],
    report: PartReport,
    decisions: tuple[Decision, ...],
    before: RcbState,
    after: RcbState,
    raw: Mapping[tuple[str, str], dict[str, Any]] | None = None,
    tool_changes: Sequence[ToolChange] = (),
) -> None:
    """Store a part's measurements and decisions, changed models, band states, setpoints.

    The setpoints are inserted now; the other rows and the plan's new pointers are deferred
    (:func:`db.bulk.defer`): they are written by :func:`db.bulk.write_deferred`, or at the
    latest when the transaction commits.

    ``part_id``: the part's row, stored by :func:`db.intake.open_report` in the same transaction;
    ``operations``: the plan's operation ids (:func:`operation_ids`). ``raw``: per
    (operation, quantity) what a measurement was converted from (a spindle reading,
    :mod:`supervisor.inputs.signals`), kept beside the converted value. ``tool_changes``: each
    reported feed override, stored as a ``feed_override_percent`` measurement with the
    commanded feed, the lower limit and whether a tool change was due.
    """
    ops = operations
    measurements: list[dict[str, Any]] = [
        {
            "part_id": part_id,
            "operation_id": ops[name],
            "quantity": quantity,
            "value": m.value,
            "uncertainty": m.uncertainty,
            "raw": (raw or {}).get((name, quantity)),
        }
        for name, measured in report.measurements.items()
        for quantity, m in measured.items()
    ]
    measurements += [
        {
            "part_id": part_id,
            "operation_id": ops[name],
            "quantity": "flank_wear_mm",
            "value": wear.flank_wear_mm.value,
            "uncertainty": wear.flank_wear_mm.uncertainty,
            "raw": {"volume_mm3": wear.volume_mm3},
        }
        for name, wear in report.tool_wear.items()
    ]
    measurements += [
        {
            "part_id": part_id,
            "operation_id": ops[c.operation],
            "quantity": "feed_override_percent",
            "value": c.feed_override_percent,
            "uncertainty": 0.0,
            "raw": {
                "commanded_feed_rate_mm_min": c.commanded_feed_rate_mm_min,
                "feed_rate_lower_mm_min": c.feed_rate_lower_mm_min,
                "tool_change_due": c.due,
                "reason": c.reason,
            },
        }
        for c in tool_changes
    ]
    decision_rows = [
        {
            "part_id": part_id,
            "operation_id": ops[d.operation],
            "quantity": d.quantity,
            "action": d.action,
            "margin": d.margin,
            "band_before": d.band_before,
            "band_after": d.band_after,
            "dK_before": d.dK_before,
            "dK_after": d.dK_after,
            "K_before": d.K_before,
            "K_after": d.K_after,
            "flagged": d.flagged,
            "reason": d.reason,
            "flag": d.flag,
            "note": d.note,
        }
        for d in decisions
    ]
    band_states = [
        {
            "operation_id": ops[d.operation],
            "quantity": d.quantity,
            "part_id": part_id,
            "seen": after.seen[(d.operation, d.quantity)],
            "sigma": after.sigma[(d.operation, d.quantity)],
            "posterior": _posterior_json(after.posterior.get((d.operation, d.quantity))),
        }
        for d in decisions
    ]
    changed = [
        (name, model)
        for name, tool in after.tools.items()
        for model in tool.models.values()
        if before.tools[name].models[model.quantity] != model
    ]
    versions = _model_version_numbers(session, plan_row.id) if changed else {}
    model_rows = [
        _model_version_row(
            ops[name], model, versions[(ops[name], model.quantity)] + 1, "part", part_id
        )
        for name, model in changed
    ]
    if after.version != before.version:
        _add_setpoints(session, plan_row.id, ops, after.setpoints, after.version, "part", part_id)
    token = new_token()
    pointers: dict[str, Any] = {
        "id": plan_row.id,
        "current_setpoint_version": after.version,
        "state_token": token,
    }
    halt = None
    if after.halt is not None and before.halt is None:  # halted now: until a replan
        halt = pointers["halt"] = halt_json(after.halt)
    # Core rows, no ORM bookkeeping; deferred, so they go out with the transaction's last rows
    defer(
        session,
        [
            (t.core_table(t.Measurement), measurements),
            (t.core_table(t.RcbDecision), decision_rows),
            (t.core_table(t.BandState), band_states),
            (t.core_table(t.OperationModelVersion), model_rows),
        ],
        updates=[(t.core_table(t.Plan), [pointers])],
    )
    plan_row.current_setpoint_version = after.version
    plan_row.state_token = token
    if halt is not None:
        plan_row.halt = halt


def _posterior_json(belief: Posterior | None) -> dict[str, Any] | None:
    return None if belief is None else belief.to_json()


def _machine(session: Session, plan: Plan) -> t.Machine:
    m = plan.machine
    limits = {
        "max_power_kW": m.max_power_kW,
        "max_spindle_rpm": m.max_spindle_rpm,
        "max_torque_Nm": m.max_torque_Nm,
        "max_feed_rate_mm_min": m.max_feed_rate_mm_min,
    }
    row = session.scalars(select(t.Machine).where(t.Machine.name == m.name)).one_or_none()
    if row is None:
        row = t.Machine(name=m.name, **limits)
        session.add(row)
        session.flush()
    elif {k: getattr(row, k) for k in limits} != limits:
        raise ConflictError("machine.name", m.name, "a machine of this name has other limits")
    return row


def operation_ids(*, session: Session, plan_row: PlanRow) -> dict[str, int]:
    """A plan's operation ids by name (cached with its state, under ``plan_row.state_token``)."""
    database = database_key(session)
    cached = CACHE.get_operations(database, plan_row.id, plan_row.state_token)
    if cached is not None:
        return cached
    ops = {name: row.id for name, row in _operations(session, plan_row.id).items()}
    CACHE.put_operations(database, plan_row.id, plan_row.state_token, ops)
    return ops


def _operations(session: Session, plan_id: int) -> dict[str, t.Operation]:
    rows = session.scalars(select(t.Operation).where(t.Operation.plan_id == plan_id))
    return {row.name: row for row in rows}


def _model_version_row(
    operation_id: int, model: PowerLawModel, version: int, cause: str, part_id: int | None
) -> dict[str, Any]:
    return {
        "operation_id": operation_id,
        "quantity": model.quantity,
        "version": version,
        "K": model.K,
        "dK": model.dK,
        "exponents": dict(model.exponents),
        "cause": cause,
        "part_id": part_id,
        "created_at": t.utcnow(),
    }


def _newest_versions(plan_id: int) -> Any:
    """Subquery: the newest model version number per (operation id, quantity) of a plan."""
    v = t.OperationModelVersion
    return (
        select(v.operation_id, v.quantity, func.max(v.version).label("version"))
        .join(t.Operation, v.operation_id == t.Operation.id)
        .where(t.Operation.plan_id == plan_id)
        .group_by(v.operation_id, v.quantity)
        .subquery()
    )


def _latest_models(session: Session, plan_id: int) -> dict[tuple[int, str], Any]:
    """The newest model version per (operation id, quantity) of a plan: K, dK, exponents."""
    v = t.OperationModelVersion
    newest = _newest_versions(plan_id)
    rows = session.execute(
        select(v.operation_id, v.quantity, v.K, v.dK, v.exponents).join(
            newest,
            (v.operation_id == newest.c.operation_id)
            & (v.quantity == newest.c.quantity)
            & (v.version == newest.c.version),
        )
    )
    return {(row.operation_id, row.quantity): row for row in rows}


def _model_version_numbers(session: Session, plan_id: int) -> dict[tuple[int, str], int]:
    """The newest model version number per (operation id, quantity) of a plan."""
    newest = _newest_versions(plan_id)
    rows = session.execute(select(newest.c.operation_id, newest.c.quantity, newest.c.version))
    return {(row.operation_id, row.quantity): row.version for row in rows}


def _latest_band_states(
    session: Session, plan_id: int, after_part: int = 0
) -> dict[tuple[int, str], t.BandState]:
    """The newest band state per (operation id, quantity) of a plan, in one query.

    States of parts up to ``after_part`` are forgotten (a replan reset the bands).
    """
    b = t.BandState
    newest = (
        select(b.operation_id, b.quantity, func.max(b.part_id).label("part_id"))
        .join(t.Operation, b.operation_id == t.Operation.id)
        .where(t.Operation.plan_id == plan_id, b.part_id > after_part)
        .group_by(b.operation_id, b.quantity)
        .subquery()
    )
    rows = session.scalars(
        select(b).join(
            newest,
            (b.operation_id == newest.c.operation_id)
            & (b.quantity == newest.c.quantity)
            & (b.part_id == newest.c.part_id),
        )
    )
    return {(row.operation_id, row.quantity): row for row in rows}


def _add_setpoints(
    session: Session,
    plan_id: int,
    ops: Mapping[str, int],
    result: PlanResult,
    version: int,
    cause: str,
    part_id: int | None,
) -> None:
    version_row = t.SetpointVersion(plan_id=plan_id, version=version, cause=cause, part_id=part_id)
    session.add(version_row)
    session.flush()
    session.execute(
        insert(t.Setpoint),
        [
            {
                "setpoint_version_id": version_row.id,
                "operation_id": ops[op.name],
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


def count_parts(*, session: Session, plan_id: int) -> int:
    """Number of parts stored for a plan."""
    return session.scalar(select(func.count()).where(t.Part.plan_id == plan_id)) or 0
