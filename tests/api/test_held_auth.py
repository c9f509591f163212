"""api.services.auth: a part report written in the transaction its API key was checked in.

On PostgreSQL the key's lookup opens the write's transaction and takes the idempotency key's
in-flight lock in the same statement; a request then uses one pooled connection for its key
check, its write and the audit entry of a refusal. On SQLite the key is read as before.
"""

from __future__ import annotations

import threading
import tomllib

import pytest
from sqlalchemy import event, func, select
from sqlalchemy.orm import Session

from api.rest.schemas.parts import parse_report
from api.services import auth
from api.services import read as queries
from api.services.errors import NotFoundError
from api.services.idempotency import Idempotency, InFlightError, fingerprint
from api.services.keys import create_key
from api.services.parts import report_part
from api.services.plans import create_plan
from db import tables as t
from db.engine import make_engine

from conftest import DEMO_PLAN, engine_url, report_at
from migrated import migrated

PLAN = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))


def _setup(url):
    migrated(url)
    engine = make_engine(url)
    key = create_key(engine=engine, role="mes")["key"]
    viewer = create_key(engine=engine, role="viewer")["key"]
    plan_id = create_plan(engine=engine, body=PLAN).body["id"]
    return engine, key, viewer, plan_id


@pytest.fixture
def setup(backend_url):
    made = _setup(backend_url)
    yield made
    made[0].dispose()


@pytest.fixture
def pg_setup(empty_postgres):
    made = _setup(empty_postgres)
    yield made
    made[0].dispose()


class Checkouts:
    """The most pool connections checked out at once while counting."""

    def __init__(self, engine) -> None:
        self.now = self.most = 0
        self.lock = threading.Lock()
        event.listen(engine, "checkout", self._out)
        event.listen(engine, "checkin", self._in)

    def _out(self, *_):
        with self.lock:
            self.now += 1
            self.most = max(self.most, self.now)

    def _in(self, *_):
        with self.lock:
            self.now -= 1


def _body(engine, plan_id, serial):
    setpoints = queries.current_setpoints(engine=engine, plan_id=plan_id)
    return report_at(serial, setpoints, {"force_N": 3.0})


def _report(engine, key, plan_id, body, idempotency_key):
    with auth.authenticated(
        engine=engine, key=key, action="POST parts", idempotency_key=idempotency_key
    ) as held:
        assert held is not None
        idem = Idempotency(idempotency_key, fingerprint("POST", f"/plans/{plan_id}/parts", body))
        return report_part(
            engine=engine,
            plan_id=plan_id,
            report=parse_report(body),
            actor=held.actor,
            idempotency=idem,
            held=held,
        )


def _audit(engine):
    with Session(engine) as session:
        rows = session.execute(select(t.AuditEntry.action, t.AuditEntry.result))
        return [tuple(r) for r in rows]


def test_a_report_and_its_replay_use_one_connection(setup):
    engine, key, _, plan_id = setup
    body = _body(engine, plan_id, "H-1")
    checkouts = Checkouts(engine)
    first = _report(engine, key, plan_id, body, "k-1")
    again = _report(engine, key, plan_id, body, "k-1")
    assert first.status == 201 and not first.replayed
    assert again.replayed and again.body == first.body
    assert checkouts.most == 1
    with Session(engine) as session:
        assert session.scalar(select(func.count()).select_from(t.Part)) == 1
    assert ("report part", "201") in _audit(engine)
    assert ("report part", "replayed 201") in _audit(engine)


def test_a_refused_report_is_audited_on_the_same_connection(setup):
    engine, key, _, plan_id = setup
    checkouts = Checkouts(engine)
    with pytest.raises(NotFoundError):
        _report(engine, key, plan_id + 1, _body(engine, plan_id, "H-2"), "k-2")
    assert checkouts.most == 1
    assert ("report part", "refused") in _audit(engine)
    with Session(engine) as session:
        assert session.scalar(select(func.count()).select_from(t.Part)) == 0
        assert session.scalar(select(func.count()).select_from(t.IdempotencyRecord)) == 0


def test_an_unknown_key_is_none_and_audited(setup):
    engine, _, _, _ = setup
    with auth.authenticated(
        engine=engine, key="rcb_wrong", action="POST parts", idempotency_key="k"
    ) as held:
        assert held is None
    assert _audit(engine)[-1] == ("POST parts", "unauthenticated")


def test_a_forbidden_role_is_audited_in_the_held_session(setup):
    engine, _, viewer, _ = setup
    checkouts = Checkouts(engine)
    with auth.authenticated(engine=engine, key=viewer, action="POST parts") as held:
        assert held is not None and held.actor.role == "viewer"
        auth.audit_forbidden(engine=engine, actor=held.actor, action="POST parts", held=held)
    assert checkouts.most == 1
    assert _audit(engine)[-1] == ("POST parts", "forbidden")


def test_the_key_lock_is_taken_with_the_key_check_on_postgresql(pg_setup):
    # (SQLite guards keys in flight with a file lock: db.keylock, tests/api/test_idempotency.py)
    engine, key, _, plan_id = pg_setup
    with auth.authenticated(
        engine=engine, key=key, action="POST parts", idempotency_key="busy"
    ) as first:
        assert first is not None and first.claimed is True
        with auth.authenticated(
            engine=engine, key=key, action="POST parts", idempotency_key="busy"
        ) as second:
            assert second is not None and second.claimed is False
            body = _body(engine, plan_id, "H-3")
            idem = Idempotency("busy", "x" * 64)
            with pytest.raises(InFlightError):
                report_part(
                    engine=engine,
                    plan_id=plan_id,
                    report=parse_report(body),
                    actor=second.actor,
                    idempotency=idem,
                    held=second,
                )
    # released with the first request's transaction: the key is free again
    assert _report(engine, key, plan_id, _body(engine, plan_id, "H-3"), "busy").status == 201


def test_every_answer_gives_the_connection_back(pg_setup):
    """Through the app: a report, a replay, a refused body (the route never runs), a 404, a
    403 and a 401 each leave no connection checked out of the pool."""
    from fastapi.testclient import TestClient

    from api.rest.app import create_app

    engine, key, viewer, plan_id = pg_setup
    app = create_app(engine_url(engine))
    pool = app.state.engine.pool
    body = _body(engine, plan_id, "H-app")
    calls = [
        (key, f"/plans/{plan_id}/parts", body, 201),
        (key, f"/plans/{plan_id}/parts", body, 201),  # the replay
        (key, f"/plans/{plan_id}/parts", {"serial": "x"}, 422),
        (key, f"/plans/{plan_id + 1}/parts", dict(body, serial="H-404"), 404),
        (viewer, f"/plans/{plan_id}/parts", body, 403),
        ("rcb_wrong", f"/plans/{plan_id}/parts", body, 401),
    ]
    with TestClient(app) as client:
        for i, (bearer, path, payload, status) in enumerate(calls):
            r = client.post(
                f"/api/v1{path}",
                json=payload,
                headers={"Authorization": f"Bearer {bearer}", "Idempotency-Key": f"a-{i // 2}"},
            )
            assert r.status_code == status, r.text
            assert pool.checkedout() == 0, (path, status)
    app.state.engine.dispose()
