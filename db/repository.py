"""Repository functions: domain objects in and out of the tables. Keyword-only, given a session.

The caller owns the transaction (one use case, one transaction: :mod:`api.service`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from db import tables as t
from db.errors import ConflictError
from db.library import ensure_tool, load_tools
from models.powerlaw import PowerLawModel, Prediction
from models.tool import Tool
from supervisor.optimizer import OperationResult, PlanResult
from supervisor.plan import Plan, plan_from_mapping
from supervisor.rcb import Decision, RcbSettings, RcbState, prior_sigma
from supervisor.report import PartReport


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
        current_setpoint_version=1,
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
    for op in plan.operations:
        for model in plan.tools[op.tool].models.values():
            session.add(_model_version(ops[op.name].id, model, 1, "initial", None))
    _add_setpoints(session, plan_row.id, ops, result, 1, "initial", None)
    return plan_row.id


def get_plan_row(*, session: Session, plan_id: int, lock: bool = False) -> t.Plan | None:
    """The plan row; ``lock`` takes a row lock (PostgreSQL) so reports of a plan serialise."""
    query = select(t.Plan).where(t.Plan.id == plan_id)
    if lock:
        query = query.with_for_update()
    return session.scalars(query).one_or_none()


def load_state(*, session: Session, plan_row: t.Plan) -> RcbState:
    """The RCB state of a plan as stored: models, band states and setpoints in force."""
    ops = _operations(session, plan_row.id)
    plan = plan_from_mapping(plan_row.body, plan_tools(session=session, plan_id=plan_row.id))
    tools: dict[str, Tool] = {}
    sigma: dict[tuple[str, str], float] = {}
    seen: dict[tuple[str, str], float] = {}
    settings = RcbSettings(strategy=plan_row.strategy, alpha=plan_row.alpha)  # type: ignore[arg-type]
    for op in plan.operations:
        base = plan.tools[op.tool]
        models = {}
        for quantity, baseline in base.models.items():
            row = _latest_model(session, ops[op.name].id, quantity)
            models[quantity] = PowerLawModel(
                quantity, row.K, row.dK, dict(row.exponents), baseline.source, baseline.reference
            )
            state = _latest_band_state(session, ops[op.name].id, quantity)
            if state is None:
                sigma[(op.name, quantity)] = prior_sigma(baseline, settings)
            else:
                sigma[(op.name, quantity)] = state.sigma
                seen[(op.name, quantity)] = state.seen
        tools[op.name] = Tool(
            base.name, base.process, models, base.description, base.material, base.source
        )
    setpoints = setpoints_of(
        session=session, plan_row=plan_row, version=plan_row.current_setpoint_version
    )
    return RcbState(
        plan, tools, setpoints, plan_row.current_setpoint_version, settings, sigma, seen
    )


def plan_tools(*, session: Session, plan_id: int) -> dict[str, Tool]:
    """The stored tools a plan's operations use (its body may name tools added over REST)."""
    names = select(t.Tool.name).join(t.Operation, t.Operation.tool_id == t.Tool.id)
    return load_tools(
        session=session, names=session.scalars(names.where(t.Operation.plan_id == plan_id))
    )


def setpoints_of(*, session: Session, plan_row: t.Plan, version: int) -> PlanResult:
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
        OperationResult(
            name=op.name,
            tool=tool.name,
            process=op.process,  # type: ignore[arg-type]
            setpoint=dict(sp.parameters),
            predicted={q: Prediction(p["value"], p["band"]) for q, p in sp.predicted.items()},
            mrr_cm3_min=sp.mrr_cm3_min,
            time_min=sp.time_min,
            binding=tuple(sp.binding),
        )
        for sp, op, tool in rows
    )
    return PlanResult(plan_row.name, machine.name if machine else "", results)


def serial_exists(*, session: Session, plan_id: int, serial: str) -> bool:
    """Whether a part with this serial was already reported for the plan."""
    query = select(t.Part.id).where(t.Part.plan_id == plan_id, t.Part.serial == serial)
    return session.scalars(query).first() is not None


def add_part(
    *,
    session: Session,
    plan_row: t.Plan,
    report: PartReport,
    decisions: tuple[Decision, ...],
    before: RcbState,
    after: RcbState,
) -> int:
    """Store a part, its measurements and decisions, changed models, band states, setpoints."""
    ops = _operations(session, plan_row.id)
    part = t.Part(
        plan_id=plan_row.id, serial=report.serial, setpoint_version=report.setpoint_version
    )
    session.add(part)
    session.flush()
    for name, measured in report.measurements.items():
        for quantity, m in measured.items():
            session.add(
                t.Measurement(
                    part_id=part.id,
                    operation_id=ops[name].id,
                    quantity=quantity,
                    value=m.value,
                    uncertainty=m.uncertainty,
                    raw=None,
                )
            )
    for name, wear in report.tool_wear.items():
        session.add(
            t.Measurement(
                part_id=part.id,
                operation_id=ops[name].id,
                quantity="flank_wear_mm",
                value=wear.flank_wear_mm.value,
                uncertainty=wear.flank_wear_mm.uncertainty,
                raw={"volume_mm3": wear.volume_mm3},
            )
        )
    for d in decisions:
        session.add(
            t.RcbDecision(
                part_id=part.id,
                operation_id=ops[d.operation].id,
                quantity=d.quantity,
                action=d.action,
                margin=d.margin,
                band_before=d.band_before,
                band_after=d.band_after,
                dK_before=d.dK_before,
                dK_after=d.dK_after,
                K_before=d.K_before,
                K_after=d.K_after,
                flagged=d.flagged,
                reason=d.reason,
            )
        )
        key = (d.operation, d.quantity)
        session.add(
            t.BandState(
                operation_id=ops[d.operation].id,
                quantity=d.quantity,
                part_id=part.id,
                seen=after.seen[key],
                sigma=after.sigma[key],
            )
        )
    for name, tool in after.tools.items():
        for quantity, model in tool.models.items():
            if before.tools[name].models[quantity] != model:
                latest = _latest_model(session, ops[name].id, quantity)
                session.add(
                    _model_version(ops[name].id, model, latest.version + 1, "part", part.id)
                )
    if after.version != before.version:
        _add_setpoints(session, plan_row.id, ops, after.setpoints, after.version, "part", part.id)
        plan_row.current_setpoint_version = after.version
    session.flush()
    return part.id


def _machine(session: Session, plan: Plan) -> t.Machine:
    m = plan.machine
    limits = {k: v for k, v in asdict(m).items() if k != "name"}
    row = session.scalars(select(t.Machine).where(t.Machine.name == m.name)).one_or_none()
    if row is None:
        row = t.Machine(name=m.name, **limits)
        session.add(row)
        session.flush()
    elif {k: getattr(row, k) for k in limits} != limits:
        raise ConflictError("machine.name", m.name, "a machine of this name has other limits")
    return row


def _operations(session: Session, plan_id: int) -> dict[str, t.Operation]:
    rows = session.scalars(select(t.Operation).where(t.Operation.plan_id == plan_id))
    return {row.name: row for row in rows}


def _model_version(
    operation_id: int, model: PowerLawModel, version: int, cause: str, part_id: int | None
) -> t.OperationModelVersion:
    return t.OperationModelVersion(
        operation_id=operation_id,
        quantity=model.quantity,
        version=version,
        K=model.K,
        dK=model.dK,
        exponents=dict(model.exponents),
        cause=cause,
        part_id=part_id,
    )


def _latest_model(session: Session, operation_id: int, quantity: str) -> t.OperationModelVersion:
    return session.scalars(
        select(t.OperationModelVersion)
        .where(
            t.OperationModelVersion.operation_id == operation_id,
            t.OperationModelVersion.quantity == quantity,
        )
        .order_by(t.OperationModelVersion.version.desc())
        .limit(1)
    ).one()


def _latest_band_state(session: Session, operation_id: int, quantity: str) -> t.BandState | None:
    return session.scalars(
        select(t.BandState)
        .where(t.BandState.operation_id == operation_id, t.BandState.quantity == quantity)
        .order_by(t.BandState.part_id.desc())
        .limit(1)
    ).one_or_none()


def _add_setpoints(
    session: Session,
    plan_id: int,
    ops: Mapping[str, t.Operation],
    result: PlanResult,
    version: int,
    cause: str,
    part_id: int | None,
) -> None:
    version_row = t.SetpointVersion(plan_id=plan_id, version=version, cause=cause, part_id=part_id)
    session.add(version_row)
    session.flush()
    for op in result.operations:
        session.add(
            t.Setpoint(
                setpoint_version_id=version_row.id,
                operation_id=ops[op.name].id,
                parameters=dict(op.setpoint),
                predicted={q: {"value": p.value, "band": p.band} for q, p in op.predicted.items()},
                binding=list(op.binding),
                mrr_cm3_min=op.mrr_cm3_min,
                time_min=op.time_min,
            )
        )


def count_parts(*, session: Session, plan_id: int) -> int:
    """Number of parts stored for a plan."""
    return session.scalar(select(func.count()).where(t.Part.plan_id == plan_id)) or 0
