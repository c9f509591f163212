"""A database another client holds locked does not lock the service out (a lockout review).

PostgreSQL: a plan's row held by another client (a transaction left open in psql) made that
plan's reports wait without end, each holding a pooled connection, until the pool ran dry and
other plans' reports were refused too. Now rcb's connections carry ``lock_timeout``
(db/engine.py): the held plan's report is 503 ``database_busy`` after it, nothing stored, and
another plan's report goes on meanwhile. SQLite: the key's last use, written before a report,
waited the whole busy timeout (30 s) for a lock held elsewhere, and the report then waited as
long again; it now waits at most ``TOUCH_WAIT_MS`` and the connection keeps its busy timeout.
"""

from __future__ import annotations

import sqlite3
import threading
from typing import Any

from sqlalchemy import text

from api.services import auth
from api.services.keys import create_key
from db.engine import PG_LOCK_TIMEOUT_MS, SQLITE_BUSY_TIMEOUT_MS, make_engine, upgrade

from conftest import report_at, step1_plan
from live import LiveServer


def _plan(live: LiveServer, name: str) -> tuple[int, dict[str, Any]]:
    with live.client("engineer") as c:
        created = c.post("/plans", json={**step1_plan(), "name": name})
        assert created.status_code == 201, created.text
        plan_id = created.json()["id"]
        return plan_id, c.get(f"/plans/{plan_id}/setpoints").json()


def test_a_plan_row_held_elsewhere_is_503_and_other_plans_go_on(empty_postgres, tmp_path):
    live = LiveServer(empty_postgres, tmp_path / "serve.log")
    live.start()
    engine = make_engine(empty_postgres)
    try:
        held, held_setpoints = _plan(live, "held")
        free, free_setpoints = _plan(live, "free")
        with engine.connect() as blocker, live.client("mes") as c:
            blocker.execute(text("SELECT id FROM plans WHERE id = :p FOR UPDATE"), {"p": held})
            key = {"Idempotency-Key": "held-1"}
            body = report_at("H1", held_setpoints)
            refused = c.post(f"/plans/{held}/parts", json=body, headers=key)
            assert refused.status_code == 503, refused.text  # before: no answer, ever
            assert refused.json()["code"] == "database_busy"
            assert refused.headers["Retry-After"] == "1"
            other = c.post(
                f"/plans/{free}/parts",
                json=report_at("F1", free_setpoints),
                headers={"Idempotency-Key": "free-1"},
            )
            assert other.status_code == 201, other.text
            assert c.get(f"/plans/{held}/parts").json()["items"] == []  # nothing half-stored
            blocker.rollback()
            retried = c.post(f"/plans/{held}/parts", json=body, headers=key)
            assert retried.status_code == 201, retried.text
    finally:
        engine.dispose()
        live.stop()
    assert "Traceback" not in live.log.read_text()


def test_rcb_connections_carry_the_lock_timeout(empty_postgres):
    upgrade(empty_postgres)
    engine = make_engine(empty_postgres)
    try:
        with engine.connect() as c:
            shown = c.execute(text("SHOW lock_timeout")).scalar_one()
    finally:
        engine.dispose()
    assert shown == f"{PG_LOCK_TIMEOUT_MS // 1000}s"


def test_a_key_last_use_waits_briefly_for_a_sqlite_lock_held_elsewhere(tmp_path):
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    upgrade(url)
    engine = make_engine(url)
    key_id = create_key(engine=engine, role="mes")["id"]
    other = sqlite3.connect(tmp_path / "rcb.db", isolation_level=None)
    try:
        other.execute("BEGIN IMMEDIATE")  # another process's write transaction, left open
        touched = threading.Thread(target=auth._touch, args=(engine, key_id), daemon=True)
        touched.start()
        touched.join(10.0)  # before: the busy timeout, 30 s
        assert not touched.is_alive()
        other.execute("ROLLBACK")
        with engine.connect() as c:  # the pooled connection went back with its own timeout
            assert c.exec_driver_sql("PRAGMA busy_timeout").scalar_one() == SQLITE_BUSY_TIMEOUT_MS
            assert c.exec_driver_sql("SELECT last_used_at FROM api_keys").scalar_one() is None
        auth._touch(engine, key_id)  # free again: written
        with engine.connect() as c:
            assert c.exec_driver_sql("SELECT last_used_at FROM api_keys").scalar_one() is not None
    finally:
        other.close()
        engine.dispose()


def test_ready_says_a_locked_database_cannot_take_reports_health_that_the_process_answers(
    sqlite_server, tmp_path
):
    """A lockout review: with the SQLite file locked by another process /health said ok and
    nothing said that every report would wait 30 s for a 503. GET /ready probes the write lock
    for at most 1 s."""
    import httpx

    path = sqlite_server.url.removeprefix("sqlite:///")
    with httpx.Client(base_url=sqlite_server.base, timeout=60) as c:
        assert c.get("/ready").json() == {"status": "ready"}
        other = sqlite3.connect(path, isolation_level=None)
        try:
            other.execute("BEGIN IMMEDIATE")  # another process's write transaction, left open
            busy = c.get("/ready")
            assert c.get("/health").json() == {"status": "ok"}  # the process answers
        finally:
            other.execute("ROLLBACK")
            other.close()
        assert busy.status_code == 503 and busy.headers["Retry-After"] == "1"
        assert busy.json()["code"] == "database_busy"
        assert busy.json()["detail"] == "the database is locked by another writer; retry later"
        assert c.get("/ready").status_code == 200
