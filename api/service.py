"""Use cases, each one transaction: load, decide with supervisor/, save with db/.

The CLI and (next) the REST routes call these; neither re-implements them.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from sqlalchemy import Engine
from sqlalchemy.orm import Session

from api import render
from db import repository as repo
from models.errors import InputError
from supervisor.optimizer import optimize_plan
from supervisor.plan import plan_from_mapping
from supervisor.rcb import RcbSettings, update
from supervisor.report import report_from_mapping


class NotFoundError(LookupError):
    """No such plan (or other stored object)."""

    def __init__(self, field: str, value: object) -> None:
        self.field, self.value = field, value
        super().__init__(f"{field} = {value!r}: not found")


def create_plan(
    *, engine: Engine, body: Mapping[str, Any], strategy: str = "ivester", alpha: float = 0.25
) -> dict[str, Any]:
    """Check and optimise a plan, store it with setpoint version 1."""
    plan = plan_from_mapping(body)
    settings = RcbSettings(strategy=strategy, alpha=alpha)  # type: ignore[arg-type]
    result = optimize_plan(plan)
    with Session(engine) as session, session.begin():
        plan_id = repo.add_plan(
            session=session, body=body, plan=plan, result=result, settings=settings
        )
    return {"id": plan_id, "name": plan.name, "setpoint_version": 1, **_operations(result)}


def current_setpoints(*, engine: Engine, plan_id: int) -> dict[str, Any]:
    """The setpoints in force."""
    with Session(engine) as session, session.begin():
        row = _plan(session, plan_id)
        version = row.current_setpoint_version
        result = repo.setpoints_of(session=session, plan_row=row, version=version)
    return {"plan_id": plan_id, "setpoint_version": version, **_operations(result)}


def report_part(*, engine: Engine, plan_id: int, body: Mapping[str, Any]) -> dict[str, Any]:
    """Apply one part report: RCB at the version the part was made with, all or nothing."""
    report = report_from_mapping(body)
    with Session(engine) as session, session.begin():
        row = _plan(session, plan_id, lock=True)
        if repo.serial_exists(session=session, plan_id=plan_id, serial=report.serial):
            raise repo.ConflictError("serial", report.serial, "already reported for this plan")
        state = repo.load_state(session=session, plan_row=row)
        made_with = None
        if report.setpoint_version != state.version:
            if not 1 <= report.setpoint_version < state.version:
                raise InputError(
                    "setpoint_version",
                    report.setpoint_version,
                    f"unknown: the plan's versions are 1..{state.version}",
                )
            made_with = repo.setpoints_of(
                session=session, plan_row=row, version=report.setpoint_version
            )
        new_state, decisions = update(state, report, made_with)
        part_id = repo.add_part(
            session=session,
            plan_row=row,
            report=report,
            decisions=decisions,
            before=state,
            after=new_state,
        )
    updates = [
        {
            "operation": d.operation,
            "quantity": d.quantity,
            "action": d.action,
            "margin": d.margin,
            "band_before": d.band_before,
            "band_after": d.band_after,
            "predicted": d.predicted,
            "measured": d.measured,
            "flagged": d.flagged,
            "reason": d.reason,
        }
        for d in decisions
    ]
    return {
        "part_id": part_id,
        "serial": report.serial,
        "setpoint_version": new_state.version,
        "updates": updates,
        **_operations(new_state.setpoints),
    }


def _plan(session: Session, plan_id: int, lock: bool = False) -> Any:
    row = repo.get_plan_row(session=session, plan_id=plan_id, lock=lock)
    if row is None:
        raise NotFoundError("plan_id", plan_id)
    return row


def _operations(result: Any) -> dict[str, Any]:
    return {"operations": render.plan_json(result)["operations"]}
