"""A part report's first step: lock the plan, store the part's row, find a stored answer.

What :func:`open_report` returns decides how the report goes on
(:func:`api.services.parts.report_part`):
a stored answer under the request's Idempotency-Key (a replay, or a key reused with another
body), no plan (404), no part row (the serial was reported: 409; or the setpoint version is
unknown: 422), or the plan's head and the new part's id.

On PostgreSQL it is one statement::

    WITH plan AS (SELECT ... FROM plans WHERE id = :plan_id FOR UPDATE),
         stored AS (SELECT ... FROM idempotency_records WHERE api_key_id = ... AND key = ...),
         part AS (INSERT INTO parts ... SELECT ... FROM plan WHERE the version is known
                  AND NOT EXISTS (SELECT FROM stored)
                  ON CONFLICT (plan_id, serial) DO NOTHING RETURNING id)
    SELECT plan.*, (SELECT id FROM part), stored.* FROM (SELECT) LEFT JOIN plan ... LEFT JOIN stored

Why one statement may read the stored answer: the idempotency key's in-flight lock is taken
by an earlier statement of the same transaction (:func:`db.api_keys.authenticate_claiming` or
:func:`db.idempotency.claim_key`). Only the lock's holder writes a key's record, and a statement's
snapshot (READ COMMITTED) is taken when it starts, after every earlier holder committed. The
plan's row lock may wait for another report of the plan; ``FOR UPDATE`` then returns the row
as that report committed it (PostgreSQL docs, "Read Committed Isolation Level"), and the
part's insert reads the locked row. A concurrent insert of the same serial is waited for by
``ON CONFLICT``, which checks the index, not the snapshot.

Elsewhere (SQLite, whose writers are serialised by ``BEGIN IMMEDIATE``) the same steps are
separate statements, in the same order.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy import JSON, Boolean, Float, Integer, String, select, text
from sqlalchemy.dialects import postgresql, sqlite
from sqlalchemy.orm import Session

from db import tables as t
from db.table_base import as_utc


@dataclass
class PlanHead:
    """The columns of a plan's row a part report needs (not its body)."""

    id: int
    name: str
    machine_id: int
    current_setpoint_version: int
    state_token: str
    settings: dict[str, Any] | None
    halt: dict[str, Any] | None
    prior: dict[str, Any] | None
    noise_prior: dict[str, Any] | None
    fleet_changes_accepted: int = 0
    fleet_change_part: int | None = None
    fleet_change_confirmed: bool = False


@dataclass(frozen=True)
class StoredAnswer:
    """A completed request stored under an Idempotency-Key."""

    request_hash: str
    status: int
    body: dict[str, Any]


@dataclass(frozen=True)
class Opening:
    """What :func:`open_report` found and did."""

    plan: PlanHead | None
    part_id: int | None
    stored: StoredAnswer | None


_HEAD = (
    "id",
    "name",
    "machine_id",
    "current_setpoint_version",
    "state_token",
    "settings",
    "halt",
    "prior",
    "noise_prior",
    "fleet_changes_accepted",
    "fleet_change_part",
    "fleet_change_confirmed",
)
_PLANS = t.core_table(t.Plan)
_PARTS = t.core_table(t.Part)

_OPEN = """
WITH plan AS (
    SELECT {head} FROM plans WHERE id = :plan_id FOR UPDATE
), stored AS (
    SELECT request_hash, response_status, response_body FROM idempotency_records
    WHERE {key_match}
), part AS (
    INSERT INTO parts (plan_id, serial, setpoint_version, received_at)
    SELECT plan.id, CAST(:serial AS VARCHAR), :setpoint_version, :received_at FROM plan
    WHERE :setpoint_version BETWEEN 1 AND plan.current_setpoint_version
      AND NOT EXISTS (SELECT FROM stored)
    ON CONFLICT (plan_id, serial) DO NOTHING
    RETURNING id
)
SELECT {plan_head}, (SELECT id FROM part) AS part_id,
       stored.request_hash, stored.response_status, stored.response_body
FROM (SELECT) AS one LEFT JOIN plan ON true LEFT JOIN stored ON true
"""
_KEY_MATCH = {
    "key": "api_key_id = :api_key_id AND key = :key",
    "cli key": "api_key_id IS NULL AND key = :key",
    "no key": "false",
}
_STATEMENTS = {
    kind: text(
        _OPEN.format(
            head=", ".join(_HEAD),
            key_match=match,
            plan_head=", ".join(f"plan.{c}" for c in _HEAD),
        )
    ).columns(
        id=Integer,
        name=String,
        machine_id=Integer,
        strategy=String,
        alpha=Float,
        current_setpoint_version=Integer,
        state_token=String,
        settings=JSON,
        halt=JSON,
        prior=JSON,
        noise_prior=JSON,
        fleet_changes_accepted=Integer,
        fleet_change_part=Integer,
        fleet_change_confirmed=Boolean,
        part_id=Integer,
        request_hash=String,
        response_status=Integer,
        response_body=JSON,
    )
    for kind, match in _KEY_MATCH.items()
}


def open_report(
    *,
    session: Session,
    plan_id: int,
    serial: str,
    setpoint_version: int,
    idempotency: tuple[int | None, str] | None,
) -> Opening:
    """Lock the plan, find the answer stored under ``idempotency``, store the part's row.

    ``idempotency``: (API key id, Idempotency-Key), or None. The part's row is stored only if
    the plan exists, ``setpoint_version`` is one of its versions, no answer is stored under
    the key and the serial was not reported for the plan.
    """
    if session.get_bind().dialect.name == "postgresql":
        return _open_in_one(session, plan_id, serial, setpoint_version, idempotency)
    stored = stored_answer(session, *idempotency) if idempotency is not None else None
    row = session.execute(select(*(_PLANS.c[c] for c in _HEAD)).where(_PLANS.c.id == plan_id))
    found = row.one_or_none()
    if found is None:
        return Opening(None, None, stored)
    plan = PlanHead(*found)
    part_id = None
    if stored is None and 1 <= setpoint_version <= plan.current_setpoint_version:
        part_id = insert_part(
            session=session, plan_id=plan_id, serial=serial, setpoint_version=setpoint_version
        )
    return Opening(plan, part_id, stored)


def _open_in_one(
    session: Session,
    plan_id: int,
    serial: str,
    setpoint_version: int,
    idempotency: tuple[int | None, str] | None,
) -> Opening:
    if idempotency is None:
        kind, api_key_id, key = "no key", None, None
    else:
        api_key_id, key = idempotency
        kind = "key" if api_key_id is not None else "cli key"
    params = {
        "plan_id": plan_id,
        "serial": serial,
        # the column is a 32-bit integer: a version beyond it is unknown, and the statement
        # would fail converting it; 0 is unknown too (the caller tells which answer applies)
        "setpoint_version": setpoint_version if 1 <= setpoint_version <= t.MAX_INT else 0,
        "received_at": t.utcnow(),
        "api_key_id": api_key_id,
        "key": key,
    }
    row = session.execute(_STATEMENTS[kind], params).one()
    plan = None if row.id is None else PlanHead(*(getattr(row, c) for c in _HEAD))
    stored = None
    if row.request_hash is not None:
        stored = StoredAnswer(row.request_hash, row.response_status or 200, row.response_body)
    return Opening(plan, row.part_id, stored)


def stored_answer(session: Session, api_key_id: int | None, key: str) -> StoredAnswer | None:
    """The completed request stored under ``key`` for this API key, if any."""
    r = t.IdempotencyRecord
    query = select(r.request_hash, r.response_status, r.response_body).where(
        r.api_key_id == api_key_id, r.key == key
    )
    found = session.execute(query).one_or_none()
    if found is None:
        return None
    return StoredAnswer(found.request_hash, found.response_status or 200, found.response_body)


def insert_part(
    *, session: Session, plan_id: int, serial: str, setpoint_version: int
) -> int | None:
    """Store a part's row and return its id; None, storing nothing, if the serial is reported.

    One statement (``INSERT ... ON CONFLICT (plan_id, serial) DO NOTHING RETURNING id``) does
    the check and the insert: a serial reported before, or by a concurrent transaction that
    commits first, returns no row.
    """
    dialect = postgresql if session.get_bind().dialect.name == "postgresql" else sqlite
    statement = (
        dialect.insert(_PARTS)
        .values(
            plan_id=plan_id,
            serial=serial,
            setpoint_version=setpoint_version,
            received_at=t.utcnow(),
        )
        .on_conflict_do_nothing(index_elements=["plan_id", "serial"])
        .returning(_PARTS.c.id)
    )
    part_id = session.connection().execute(statement).scalar()
    return None if part_id is None else int(part_id)


def reported(*, session: Session, plan_id: int, serial: str) -> tuple[int, datetime] | None:
    """The id and time (UTC) of the plan's part of this serial, if one was reported."""
    query = select(t.Part.id, t.Part.received_at).where(
        t.Part.plan_id == plan_id, t.Part.serial == serial
    )
    row = session.execute(query).first()
    return None if row is None else (row.id, as_utc(row.received_at))
