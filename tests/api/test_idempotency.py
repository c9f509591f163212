"""Idempotency-Key semantics at the service layer, on SQLite and PostgreSQL."""

from __future__ import annotations

import tomllib

import pytest
from sqlalchemy import func, select, text
from sqlalchemy.orm import Session

from api.rest.schemas.parts import parse_report
from api.services import read as queries
from api.services.idempotency import Idempotency, InFlightError, KeyReuseError, fingerprint
from api.services.keys import create_key
from api.services.parts import report_part
from api.services.plans import create_plan
from db import idempotency, keylock
from db import tables as t
from db.api_keys import Actor

from conftest import DEMO_PLAN, report_at

PLAN = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))


def _setup(engine):
    key_id = create_key(engine=engine, role="mes")["id"]
    actor = Actor(key_id, "mes", f"key:{key_id}")
    plan_id = create_plan(engine=engine, body=PLAN).body["id"]
    setpoints = queries.current_setpoints(engine=engine, plan_id=plan_id)
    return actor, plan_id, setpoints


def _idem(key, plan_id, body):
    return Idempotency(key, fingerprint("POST", f"/plans/{plan_id}/parts", body))


def _count(engine, table):
    with Session(engine) as session:
        return session.scalar(select(func.count()).select_from(table))


def test_a_completed_key_returns_the_stored_response_and_writes_nothing(engine):
    actor, plan_id, setpoints = _setup(engine)
    body = report_at("I1", setpoints, {"force_N": 3.0})
    first = report_part(
        engine=engine,
        plan_id=plan_id,
        report=parse_report(body),
        actor=actor,
        idempotency=_idem("k", plan_id, body),
    )
    assert first.status == 201 and not first.replayed
    counts = [_count(engine, x) for x in (t.Part, t.RcbDecision, t.SetpointVersion)]
    again = report_part(
        engine=engine,
        plan_id=plan_id,
        report=parse_report(body),
        actor=actor,
        idempotency=_idem("k", plan_id, body),
    )
    assert again.replayed and again.status == 201 and again.body == first.body
    assert [_count(engine, x) for x in (t.Part, t.RcbDecision, t.SetpointVersion)] == counts
    other = {**body, "serial": "I2"}
    with pytest.raises(KeyReuseError):
        report_part(
            engine=engine,
            plan_id=plan_id,
            report=parse_report(other),
            actor=actor,
            idempotency=_idem("k", plan_id, other),
        )
    # another client's key of the same name is its own
    other_actor = Actor(None, "engineer", "cli")
    fresh = report_part(
        engine=engine,
        plan_id=plan_id,
        report=parse_report(other),
        actor=other_actor,
        idempotency=_idem("k", plan_id, other),
    )
    assert fresh.status == 201 and not fresh.replayed


def test_a_key_in_flight_is_refused_and_free_again_after(engine):
    actor, plan_id, setpoints = _setup(engine)
    body = report_at("F1", setpoints, {"force_N": 3.0})
    scope = f"{actor.id}:busy"
    if engine.dialect.name == "sqlite":
        holder = keylock.in_flight(engine, scope)
        assert holder.__enter__() is True  # as a running request would hold it
        release = holder.__exit__
    else:
        lock = idempotency.KEY_LOCK.format(api_key_id=":api_key_id")
        connection = engine.connect()
        transaction = connection.begin()
        connection.execute(
            text(f"SELECT pg_advisory_xact_lock({lock})"),
            {"idempotency_key": "busy", "api_key_id": actor.id or 0},
        )

        def release(*_):
            transaction.rollback()
            connection.close()

    try:
        with pytest.raises(InFlightError):
            report_part(
                engine=engine,
                plan_id=plan_id,
                report=parse_report(body),
                actor=actor,
                idempotency=_idem("busy", plan_id, body),
            )
    finally:
        release(None, None, None)
    assert _count(engine, t.Part) == 0
    done = report_part(
        engine=engine,
        plan_id=plan_id,
        report=parse_report(body),
        actor=actor,
        idempotency=_idem("busy", plan_id, body),
    )
    assert done.status == 201


def test_a_refused_report_stores_no_key_and_is_audited(engine):
    actor, plan_id, setpoints = _setup(engine)
    # refused by the service (the plan has no such operation), not at the edge (the schema):
    # the edge refuses before anything is opened, the service inside the audited transaction
    bad = report_at("B1", setpoints, {"force_N": 3.0})
    bad["operations"][0]["name"] = "no-such-operation"
    with pytest.raises(ValueError, match="not an operation of"):
        report_part(
            engine=engine,
            plan_id=plan_id,
            report=parse_report(bad),
            actor=actor,
            idempotency=_idem("b", plan_id, bad),
        )
    assert _count(engine, t.IdempotencyRecord) == 0
    good = report_at("B1", setpoints, {"force_N": 3.0})  # the corrected report may reuse the key
    fixed = report_part(
        engine=engine,
        plan_id=plan_id,
        report=parse_report(good),
        actor=actor,
        idempotency=_idem("b", plan_id, good),
    )
    assert fixed.status == 201
    with Session(engine) as session:
        results = [
            (a.action, a.result, a.actor)
            for a in session.scalars(select(t.AuditEntry).order_by(t.AuditEntry.id))
        ]
    assert ("report part", "refused", actor.name) in results
    assert ("report part", "201", actor.name) in results
