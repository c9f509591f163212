"""The use case the MES calls after every part: store it and apply RCB, all or nothing."""

from __future__ import annotations

from collections.abc import Sequence
from functools import partial
from typing import Any

from sqlalchemy import Engine
from sqlalchemy.orm import Session

from api.services import to_json
from api.services.auth import Authenticated
from api.services.errors import NotFoundError
from api.services.idempotency import Idempotency, Written, replay_of
from api.services.plans import operations_json
from api.services.transactions import audited, transaction
from db import api_keys
from db.api_keys import Actor
from db.errors import ConflictError, SerialTakenError
from db.intake import Opening, PlanHead, open_report, reported
from db.plan_state import halt_json
from db.plans import operation_ids, setpoints_of
from db.state import load_state
from db.state_cache import CACHE, database_key
from db.store_report import store_report
from models.errors import InputError, InputErrors
from supervisor.constant_load.reported_tool_changes import ToolChange, tool_changes
from supervisor.inputs.part_report import PartReport
from supervisor.inputs.signals import resolve
from supervisor.optimize.result import PlanResult
from supervisor.rcb.decision import Decision
from supervisor.rcb.state import RcbState
from supervisor.rcb.update import update


def report_part(
    *,
    engine: Engine,
    plan_id: int,
    report: PartReport,
    actor: Actor = api_keys.CLI_ACTOR,
    idempotency: Idempotency | None = None,
    held: Authenticated | None = None,
) -> Written:
    """Apply one part report: RCB at the version the part was made with, all or nothing.

    ``report``: read and checked at the edge (the REST schema,
    :func:`api.rest.schemas.parts.parse_report`); what it names is checked against the plan
    here, before anything is stored.
    ``held``: the request's authentication (its actor is ``actor``), whose transaction the
    report goes on in (:class:`Authenticated`).
    """
    target = f"plan {plan_id} part {report.serial}"
    with audited(engine, actor, "report part", target, held, plan_id):
        try:
            return _report_part(engine, plan_id, report, actor, idempotency, held)
        except InputError as err:
            raise at_body_path(err, tuple(report.measurements)) from None


def at_body_path(err: InputError, order: Sequence[str]) -> InputError:
    """``err`` naming its field by the report body's path: ``operations[1].measurements...``.

    The domain reads a report by operation name (``operations.finish-od.measurements``); the
    body lists the operations (``order``, as sent), and the schema's errors name them by index,
    so the errors found after it do too (an operation the plan lacks: ``operations[i].name``).
    """
    if isinstance(err, InputErrors):
        return InputErrors([at_body_path(e, order) for e in err.errors])
    by_length = sorted(enumerate(order), key=lambda item: -len(item[1]))
    for index, name in by_length:
        prefix = f"operations.{name}"
        if err.field == prefix or err.field.startswith(prefix + "."):
            rest = err.field[len(prefix) :] or ".name"
            return type(err)(f"operations[{index}]{rest}", err.value, err.reason)
    return err


def _report_part(
    engine: Engine,
    plan_id: int,
    report: PartReport,
    actor: Actor,
    idempotency: Idempotency | None,
    held: Authenticated | None,
) -> Written:
    target = f"plan {plan_id} part {report.serial}"
    with transaction(engine, actor, "report part", target, idempotency, held, plan=plan_id) as tx:
        session = tx.session
        opening = _open(session, plan_id, report, actor, idempotency)
        replay = replay_of(opening.stored, idempotency) if idempotency else None
        if replay is not None:
            return tx.replayed(replay)
        if opening.plan is None:
            raise NotFoundError("plan_id", plan_id)
        row = opening.plan
        state = load_state(session=session, plan_row=row)
        part_id = _accepted(session, opening.part_id, plan_id, report, state)
        operations = operation_ids(session=session, plan_row=row)
        made_with = _made_with(session, row, report.setpoint_version, state)
        # raw spindle readings become force measurements at the setpoint the part was made with
        measured, raw = resolve(report, state.plan, made_with or state.setpoints)
        fastest = state.plan.machine.limit_of.get("feed_rate_mm_min")
        changes = tool_changes(report, made_with or state.setpoints, fastest)
        new_state, decisions = update(state, measured, made_with)
        token = store_report(
            session=session,
            plan_row=row,
            part_id=part_id,
            operations=operations,
            report=measured,
            decisions=decisions,
            before=state,
            after=new_state,
            raw=raw,
            tool_changes=changes,
        )
        # committed: the plan's next part starts from this state (db.state_cache)
        tx.after_commit(
            partial(CACHE.put, database_key(session), plan_id, token, new_state, operations)
        )
        return tx.answer(201, _answer(part_id, report.serial, new_state, decisions, changes))


def _open(
    session: Session,
    plan_id: int,
    report: PartReport,
    actor: Actor,
    idempotency: Idempotency | None,
) -> Opening:
    """The report's first statement (db.intake): the plan locked, the part's row, a stored answer.

    One statement on PostgreSQL: the plan's row lock, the answer stored under the key, and the
    part's row unless the serial is reported.
    """
    return open_report(
        session=session,
        plan_id=plan_id,
        serial=report.serial,
        setpoint_version=report.setpoint_version,
        idempotency=(actor.id, idempotency.key) if idempotency else None,
    )


def _accepted(
    session: Session, part_id: int | None, plan_id: int, report: PartReport, state: RcbState
) -> int:
    """The part's id; none stored: its serial was reported (409) or its version is unknown (422).

    The conflict is told first: a serial reported at an unknown version is a 409.
    """
    if part_id is not None:
        return part_id
    stored = reported(session=session, plan_id=plan_id, serial=report.serial)
    if stored is not None:
        raise SerialTakenError(report.serial, *stored)
    if 1 <= report.setpoint_version <= state.version:  # no row, none stored: not expected
        raise ConflictError("serial", report.serial, "already reported for this plan")
    raise InputError(
        "setpoint_version",
        report.setpoint_version,
        f"unknown: the plan's versions are 1..{state.version}",
    )


def _made_with(session: Session, row: PlanHead, version: int, state: RcbState) -> PlanResult | None:
    """The setpoints the part was made with if not those in force (None: those in force)."""
    if version == state.version:
        return None
    return setpoints_of(session=session, plan_row=row, version=version)


def _answer(
    part_id: int,
    serial: str,
    new_state: RcbState,
    decisions: tuple[Decision, ...],
    changes: Sequence[ToolChange],
) -> dict[str, Any]:
    """The 201 answer: the part, its decisions and tool changes, the setpoints in force.

    A halted plan: the part is stored all the same, and the MES is told (DESIGN.md, RCB); it
    is handed no setpoint (``operations`` empty), as ``GET .../setpoints`` refuses them.
    """
    halt = halt_json(new_state.halt) if new_state.halt is not None else None
    in_force = {"operations": []} if halt is not None else operations_json(new_state.setpoints)
    return {
        "part_id": part_id,
        "serial": serial,
        "setpoint_version": new_state.version,
        "halted": halt is not None,
        "conflicts": halt["conflicts"] if halt is not None else [],
        "updates": [to_json.decision_json(d) for d in decisions],
        "tool_changes": [to_json.tool_change_json(c) for c in changes],
        **in_force,
    }
