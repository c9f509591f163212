"""The use case the MES calls after every part: store it and apply RCB, all or nothing."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from sqlalchemy import Engine
from sqlalchemy.orm import Session

from api.services import to_json
from api.services.auth import Authenticated
from api.services.errors import NotFoundError
from api.services.idempotency import Idempotency, Written, replay_of
from api.services.plans import operations_json
from api.services.transactions import audited, write
from db import api_keys
from db.api_keys import Actor
from db.errors import ConflictError
from db.intake import open_report, serial_exists
from db.parts import add_part
from db.plan_state import halt_json
from db.plans import operation_ids, setpoints_of
from db.state import load_state
from db.state_cache import CACHE, database_key
from models.errors import InputError
from supervisor.constant_load.reported_tool_changes import tool_changes
from supervisor.inputs.part_report import report_from_mapping
from supervisor.inputs.signals import resolve
from supervisor.rcb.state import RcbState
from supervisor.rcb.update import update


def report_part(
    *,
    engine: Engine,
    plan_id: int,
    body: Mapping[str, Any],
    actor: Actor = api_keys.CLI_ACTOR,
    idempotency: Idempotency | None = None,
    held: Authenticated | None = None,
) -> Written:
    """Apply one part report: RCB at the version the part was made with, all or nothing.

    ``held``: the request's authentication (its actor is ``actor``), whose transaction the
    report goes on in (:class:`Authenticated`).
    """
    target = f"plan {plan_id} part {body.get('serial', '')}"
    with audited(engine, actor, "report part", target, held):
        return _report_part(engine, plan_id, body, actor, idempotency, held)


def _report_part(
    engine: Engine,
    plan_id: int,
    body: Mapping[str, Any],
    actor: Actor,
    idempotency: Idempotency | None,
    held: Authenticated | None,
) -> Written:
    report = report_from_mapping(body)

    def work(session: Session) -> tuple[int, dict[str, Any]] | Written:
        # one statement on PostgreSQL: the plan's row lock, the answer stored under the key,
        # and the part's row unless the serial is reported (db.intake)
        opening = open_report(
            session=session,
            plan_id=plan_id,
            serial=report.serial,
            setpoint_version=report.setpoint_version,
            idempotency=(actor.id, idempotency.key) if idempotency else None,
        )
        replay = replay_of(opening.stored, idempotency) if idempotency else None
        if replay is not None:
            return replay
        row, part_id = opening.plan, opening.part_id
        if row is None:
            raise NotFoundError("plan_id", plan_id)
        state = load_state(session=session, plan_row=row)
        known = 1 <= report.setpoint_version <= state.version
        if part_id is None and (
            known or serial_exists(session=session, plan_id=plan_id, serial=report.serial)
        ):  # 409 before 422
            raise ConflictError("serial", report.serial, "already reported for this plan")
        if part_id is None:
            raise InputError(
                "setpoint_version",
                report.setpoint_version,
                f"unknown: the plan's versions are 1..{state.version}",
            )
        operations = operation_ids(session=session, plan_row=row)
        made_with = None
        if report.setpoint_version != state.version:
            made_with = setpoints_of(session=session, plan_row=row, version=report.setpoint_version)
        # raw spindle readings become force measurements at the setpoint the part was made with
        measured, raw = resolve(report, state.plan, made_with or state.setpoints)
        changes = tool_changes(report, made_with or state.setpoints)
        new_state, decisions = update(state, measured, made_with)
        add_part(
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
        written_state.append((database_key(session), row.state_token, new_state, operations))
        updates = [to_json.decision_json(d) for d in decisions]
        # a halted plan: the part is stored all the same, and the MES is told (DESIGN.md, RCB)
        halt = halt_json(new_state.halt) if new_state.halt is not None else None
        return 201, {
            "part_id": part_id,
            "serial": report.serial,
            "setpoint_version": new_state.version,
            "halted": halt is not None,
            "conflicts": halt["conflicts"] if halt is not None else [],
            "updates": updates,
            "tool_changes": [to_json.tool_change_json(c) for c in changes],
            **operations_json(new_state.setpoints),
        }

    written_state: list[tuple[str, str, RcbState, dict[str, int]]] = []
    written = write(
        engine,
        actor=actor,
        action="report part",
        target=f"plan {plan_id} part {report.serial}",
        idempotency=idempotency,
        work=work,
        held=held,
        finds_replay=True,
    )
    for database, token, new_state, operations in written_state:  # committed: the next part
        CACHE.put(database, plan_id, token, new_state, operations)  # starts here
    return written
