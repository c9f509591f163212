"""Use cases that write, each one transaction: load, decide with supervisor/, save with db/.

The CLI and the REST routes call these; neither re-implements them. Every write runs through
:func:`_write`, which makes it idempotent when given an Idempotency-Key (IETF draft
"The Idempotency-Key HTTP Header Field"): the key's record is stored in the same transaction
as the write, a completed key returns its stored response, a key used with another request is
refused, and a key whose request is still running is reported in flight. Every write, and
every refused one, is appended to the audit log.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from sqlalchemy import Engine
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from api.rest.auth import Authenticated, aside
from api.services import to_json
from db import access, bulk, keylock, library
from db.access import Actor
from db.errors import ConflictError
from db.intake import StoredAnswer, open_report, serial_exists, stored_answer
from db.parts import add_part
from db.plan_state import halt_json
from db.plans import (
    add_plan,
    add_replan,
    current_body,
    get_plan_row,
    operation_ids,
    plan_tools,
    setpoints_of,
)
from db.state import load_state
from db.state_cache import CACHE, database_key
from models.catalogue import catalogue
from models.errors import InputError
from models.tool import tool_from_mapping
from supervisor.constant_load.reported_tool_changes import tool_changes
from supervisor.inputs.part_report import report_from_mapping
from supervisor.inputs.plan import plan_from_mapping
from supervisor.inputs.signals import resolve
from supervisor.optimize.optimizer import optimize_plan
from supervisor.rcb.replan import replan as supervisor_replan
from supervisor.rcb.state import RcbSettings, RcbState
from supervisor.rcb.update import update


class NotFoundError(LookupError):
    """No such plan (or other stored object)."""

    def __init__(self, field: str, value: object) -> None:
        self.field, self.value = field, value
        super().__init__(f"{field} = {value!r}: not found")


class PlanHaltedError(Exception):
    """The plan is halted: no setpoint meets its bands until an engineer replans."""

    def __init__(self, plan_id: int, halt: Mapping[str, Any]) -> None:
        self.field, self.value = "plan_id", plan_id
        self.conflicts: list[dict[str, Any]] = list(halt.get("conflicts", []))
        super().__init__(
            f"plan {plan_id} is halted: {halt.get('message', '')}; "
            "replan it (rcb replan or POST .../replan) to resume"
        )


class InFlightError(Exception):
    """A request with this Idempotency-Key is still being processed."""

    def __init__(self, key: str) -> None:
        self.field, self.value = "Idempotency-Key", key
        super().__init__(f"Idempotency-Key = {key!r}: a request with this key is in flight")


class KeyReuseError(Exception):
    """An Idempotency-Key already used for a different request."""

    def __init__(self, key: str) -> None:
        self.field, self.value = "Idempotency-Key", key
        super().__init__(
            f"Idempotency-Key = {key!r}: already used for a different request; use a new key"
        )


@dataclass(frozen=True)
class Idempotency:
    """An Idempotency-Key and the fingerprint of the request it was sent with."""

    key: str
    request_hash: str


def fingerprint(method: str, path: str, body: object) -> str:
    """SHA-256 of the method, path and canonical JSON of the body."""
    canonical = json.dumps(body, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(f"{method} {path}\n{canonical}".encode()).hexdigest()


@dataclass(frozen=True)
class Written:
    """The response of a write: status, body, and whether it is a stored replay.

    ``text``: the body's JSON as stored with the idempotency key (a new answer's, encoded
    once for the database and the HTTP answer); None for a replay.
    """

    status: int
    body: dict[str, Any]
    replayed: bool = False
    text: str | None = None


#: A write's work in its transaction: (status, body), or a replay found by the work itself.
Work = Callable[[Session], "tuple[int, dict[str, Any]] | Written"]


def _write(
    engine: Engine,
    *,
    actor: Actor,
    action: str,
    target: str,
    idempotency: Idempotency | None,
    work: Work,
    attempts: int = 1,
    held: Authenticated | None = None,
    finds_replay: bool = False,
) -> Written:
    """Run ``work`` in one transaction, idempotently; ``attempts`` > 1 retries unique-key races.

    Creating a plan inserts its machine and tools if they are new: two plans for the same new
    machine at once race to insert it, and the loser's retry finds it stored. ``held``: the
    request's authentication, whose open transaction (if any) the first attempt goes on in.
    ``finds_replay``: ``work`` looks the key's stored answer up itself (after the key's lock,
    in its first statement) and returns it as a :class:`Written`.
    """
    for attempt in range(1, attempts + 1):
        try:
            return _write_once(
                engine,
                actor=actor,
                action=action,
                target=target,
                idempotency=idempotency,
                work=work,
                held=held if attempt == 1 else None,
                finds_replay=finds_replay,
            )
        except ConflictError as err:
            if attempt == attempts or not isinstance(err.__cause__, IntegrityError):
                raise
    raise AssertionError("unreachable")


def _write_once(
    engine: Engine,
    *,
    actor: Actor,
    action: str,
    target: str,
    idempotency: Idempotency | None,
    work: Work,
    held: Authenticated | None,
    finds_replay: bool,
) -> Written:
    scope = f"{actor.id}:{idempotency.key}" if idempotency else ""
    guard = keylock.in_flight(engine, scope) if idempotency else _free()
    try:
        with guard as free:
            if not free:
                raise InFlightError(idempotency.key if idempotency else "")
            with _transaction(engine, held) as (session, claimed):
                stored = None
                if idempotency is not None:
                    if claimed is None:
                        claimed = access.claim_key(
                            session=session, api_key_id=actor.id, key=idempotency.key
                        )
                    if not claimed:
                        raise InFlightError(idempotency.key)
                    if not finds_replay:
                        stored = replay_of(
                            stored_answer(session, actor.id, idempotency.key), idempotency
                        )
                done = stored or work(session)
                if isinstance(done, Written):
                    access.audit(
                        session=session,
                        actor=actor.name,
                        action=action,
                        target=target,
                        result=f"replayed {done.status}",
                    )
                    return done
                status, body = done
                answer = bulk.Encoded.of(body)
                # the key's record and the audit entry go out with the rows the work deferred
                # (a part report's: one statement on PostgreSQL, db.bulk)
                rows = [(access.AUDIT, [access.audit_row(actor.name, action, target, str(status))])]
                if idempotency is not None:
                    record = access.idempotency_row(
                        actor.id, idempotency.key, idempotency.request_hash, status, answer
                    )
                    rows.insert(0, (access.IDEMPOTENCY, [record]))
                bulk.write_deferred(session, rows)
                return Written(status, body, text=answer.text)
    except IntegrityError as err:
        # a concurrent write won a unique constraint (same serial, same key): nothing was stored
        raise ConflictError(
            "request", target, "a concurrent request stored the same thing"
        ) from err


@contextmanager
def _transaction(
    engine: Engine, held: Authenticated | None
) -> Iterator[tuple[Session, bool | None]]:
    """A session in a transaction, committed if the block ends without an exception.

    With ``held`` that has a session: that session, in the transaction its key was checked in
    (the first time; then whether the key's lock was taken in it) or in a new one; else a new
    session, and None.
    """
    if held is None or held.session is None:
        with Session(engine) as session, session.begin():
            yield session, None
        return
    session, claimed = held.session, held.claimed
    held.claimed = None  # the lock lasts as long as the transaction it was taken in
    if not session.in_transaction():
        session.begin()
    try:
        yield session, claimed
        session.commit()
    except BaseException:
        session.rollback()
        raise


class _free:
    def __enter__(self) -> bool:
        return True

    def __exit__(self, *exc: object) -> None:
        return None


def replay_of(stored: StoredAnswer | None, idempotency: Idempotency) -> Written | None:
    """The answer stored under the key, as a replay (None if none); another request's: 422."""
    if stored is None:
        return None
    if stored.request_hash != idempotency.request_hash:
        raise KeyReuseError(idempotency.key)
    return Written(stored.status, dict(stored.body or {}), True)


@contextmanager
def _audited(
    engine: Engine, actor: Actor, action: str, target: str, held: Authenticated | None = None
) -> Iterator[None]:
    """Append a refused write (any exception) to the audit log, then let it propagate."""
    try:
        yield
    except Exception as err:
        detail = {
            "error": err.__class__.__name__,
            "field": str(getattr(err, "field", "")),
            "message": str(err)[:500],
        }
        with aside(engine, held.session if held else None) as session:
            access.audit(
                session=session,
                actor=actor.name,
                action=action,
                target=target,
                result="refused",
                detail=detail,
            )
        raise


def floors_from(items: Sequence[str], field: str) -> dict[str, float]:
    """Floors given as ``QUANTITY=VALUE`` (CLI options, query parameters), checked."""
    floors: dict[str, float] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise InputError(field, item, "must be QUANTITY=VALUE")
        try:
            number = float(value)
        except ValueError:
            raise InputError(f"{field} {name}", value, "must be a number") from None
        floors[name.strip()] = number
    return floors


def create_plan(
    *,
    engine: Engine,
    body: Mapping[str, Any],
    settings: RcbSettings | None = None,
    actor: Actor = access.CLI_ACTOR,
    idempotency: Idempotency | None = None,
) -> Written:
    """Check and optimise a plan, store it with setpoint version 1 (status 201).

    ``settings``: the plan's RCB law, every setting stored (default: :class:`RcbSettings`).
    """
    with _audited(engine, actor, "create plan", f"plan {body.get('name', '')}"):
        settings = settings or RcbSettings()
        with Session(engine) as session:
            stored_tools = library.load_tools(session=session)
        plan = plan_from_mapping(body, stored_tools)
        result = optimize_plan(plan)  # outside the write transaction: it needs no lock

        def work(session: Session) -> tuple[int, dict[str, Any]]:
            plan_id = add_plan(
                session=session, body=body, plan=plan, result=result, settings=settings
            )
            return 201, {"id": plan_id, "name": plan.name, "setpoint_version": 1, **_ops(result)}

        return _write(
            engine,
            actor=actor,
            action="create plan",
            target=f"plan {plan.name}",
            idempotency=idempotency,
            work=work,
            attempts=3,
        )


def report_part(
    *,
    engine: Engine,
    plan_id: int,
    body: Mapping[str, Any],
    actor: Actor = access.CLI_ACTOR,
    idempotency: Idempotency | None = None,
    held: Authenticated | None = None,
) -> Written:
    """Apply one part report: RCB at the version the part was made with, all or nothing.

    ``held``: the request's authentication (its actor is ``actor``), whose transaction the
    report goes on in (:class:`Authenticated`).
    """
    target = f"plan {plan_id} part {body.get('serial', '')}"
    with _audited(engine, actor, "report part", target, held):
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
            **_ops(new_state.setpoints),
        }

    written_state: list[tuple[str, str, RcbState, dict[str, int]]] = []
    written = _write(
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


def add_tool(
    *,
    engine: Engine,
    body: Mapping[str, Any],
    actor: Actor = access.CLI_ACTOR,
    idempotency: Idempotency | None = None,
) -> Written:
    """Store a new tool with its baseline models (status 201); the name must be new."""
    with _audited(engine, actor, "add tool", f"tool {body.get('name', '')}"):
        tool = tool_from_mapping(body, "")
        if tool.name in catalogue():
            raise ConflictError("name", tool.name, "a catalogue tool has this name")

        def work(session: Session) -> tuple[int, dict[str, Any]]:
            library.add_tool(session=session, tool=tool)
            return 201, to_json.tool_json(tool)

        return _write(
            engine,
            actor=actor,
            action="add tool",
            target=f"tool {tool.name}",
            idempotency=idempotency,
            work=work,
        )


def create_key(*, engine: Engine, role: str, label: str = "") -> dict[str, Any]:
    """A new API key of ``role``, printed once: ``{"key", "role", "id"}``."""
    if role not in access.ROLES:
        raise InputError("--role", role, f"expected one of: {', '.join(access.ROLES)}")
    with Session(engine) as session, session.begin():
        key_id, key = access.create_key(session=session, role=role, label=label)
        access.audit(
            session=session, actor="cli", action="create key", target=f"key {key_id}", result=role
        )
    return {"key": key, "role": role, "id": key_id}


def revoke_key(*, engine: Engine, key_id: int) -> dict[str, Any]:
    """Revoke an API key; it stays stored for the audit log."""
    with Session(engine) as session, session.begin():
        row = access.revoke_key(session=session, key_id=key_id)
        if row is None:
            raise NotFoundError("ID", key_id)
        access.audit(
            session=session, actor="cli", action="revoke key", target=f"key {key_id}", result="ok"
        )
        return {"id": key_id, "role": row.role, "revoked_at": row.revoked_at}


def _plan(session: Session, plan_id: int, lock: bool = False) -> Any:
    row = get_plan_row(session=session, plan_id=plan_id, lock=lock)
    if row is None:
        raise NotFoundError("plan_id", plan_id)
    return row


def _ops(result: Any) -> dict[str, Any]:
    return {"operations": to_json.plan_json(result)["operations"]}


def replan(
    *,
    engine: Engine,
    plan_id: int,
    changes: Mapping[str, Any],
    dry_run: bool = False,
    actor: Actor = access.CLI_ACTOR,
    idempotency: Idempotency | None = None,
) -> Written:
    """Apply an engineer's change and re-optimise; unless ``dry_run``, store it.

    The new setpoint version has cause ``replan``; the answer shows the difference to the
    setpoints in force (:mod:`supervisor.rcb.replan`).
    """
    with _audited(engine, actor, "replan", f"plan {plan_id}"):

        def work(session: Session) -> tuple[int, dict[str, Any]]:
            row = _plan(session, plan_id, lock=True)
            before = load_state(session=session, plan_row=row)
            body = current_body(session=session, plan_row=row)
            library = plan_tools(session=session, plan_id=plan_id)
            library.update(library_tools(session))
            done = supervisor_replan(before, body, changes, library)
            if not dry_run:
                add_replan(
                    session=session,
                    plan_row=row,
                    body=done.body,
                    changes=dict(changes),
                    reset_bands=done.reset_bands,
                    before=before,
                    after=done.state,
                    actor=actor.name,
                )
            answer = _replan_answer(plan_id, before, done, dry_run)
            return (200 if dry_run else 201), answer

        if dry_run:
            with Session(engine) as session:
                session.begin()
                try:
                    status, body = work(session)
                finally:
                    session.rollback()  # a dry run stores nothing
            return Written(status, body)
        return _write(
            engine,
            actor=actor,
            action="replan",
            target=f"plan {plan_id}",
            idempotency=idempotency,
            work=work,
        )


def library_tools(session: Session) -> dict[str, Any]:
    """Every stored tool (a replan may name a tool added over REST)."""
    return library.load_tools(session=session)


def _replan_answer(plan_id: int, before: RcbState, done: Any, dry_run: bool) -> dict[str, Any]:
    old = {op.name: op for op in before.setpoints.operations}
    diff = []
    for op in done.state.setpoints.operations:
        was = old[op.name]
        diff.append(
            {
                "operation": op.name,
                "setpoint": {k: [was.setpoint.get(k), v] for k, v in op.setpoint.items()},
                "mrr_cm3_min": [was.mrr_cm3_min, op.mrr_cm3_min],
                "binding": [list(was.binding), list(op.binding)],
            }
        )
    return {
        "plan_id": plan_id,
        "dry_run": dry_run,
        "setpoint_version": before.version if dry_run else done.state.version,
        "reset_bands": done.reset_bands,
        "cycle_time_min": [before.setpoints.cycle_time_min, done.state.setpoints.cycle_time_min],
        "diff": diff,
        **_ops(done.state.setpoints),
    }
