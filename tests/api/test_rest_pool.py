"""Database connections run out: 503 with Retry-After, never a 500 or a dropped connection.

Issue 29: 2 instances x 2 workers and a burst of 120 clients on PostgreSQL opened 96 server
connections against the default ``max_connections`` 100: 5 x 500, 5 connections dropped with no
answer, "sorry, too many clients already". Now each worker opens at most
``db.engine.Pool().connections()`` (16), a request waits at most the pool's timeout for one,
then is 503 ``database_busy`` with ``Retry-After`` (api/rest/unavailable.py).
"""

from __future__ import annotations

import sqlite3
import threading
import time
import uuid
from collections import Counter
from typing import Any

import httpx
import pytest
from sqlalchemy import text
from sqlalchemy.exc import OperationalError
from sqlalchemy.exc import TimeoutError as PoolTimeoutError

from api import settings
from api.cli.main import app
from api.rest.unavailable import unavailable
from db.engine import Pool, make_engine

from conftest import report_at, step1_plan
from live import LOOPBACK_TLS, LiveServer

INSTANCES, WORKERS, CLIENTS, REPORTS = 2, 2, 120, 2
#: Bounds of the load test: every request, every client's retries, the whole burst [s].
REQUEST_S, DEADLINE_S, ATTEMPTS = 30.0, 90.0, 20


def _serve(url: str, tmp_path, monkeypatch, name: str, **env: str) -> LiveServer:
    for variable, value in env.items():
        monkeypatch.setenv(variable, value)
    live = LiveServer(url, tmp_path / f"{name}.log", workers=WORKERS)
    live.start()
    return live


def _plan(live: LiveServer) -> tuple[int, dict[str, Any]]:
    with live.client("engineer") as c:
        created = c.post("/plans", json=step1_plan())
        assert created.status_code == 201, created.text
        plan_id = created.json()["id"]
        return plan_id, c.get(f"/plans/{plan_id}/setpoints").json()


def _is_503(r: httpx.Response) -> bool:
    """A 503 as promised: problem+json, code database_busy, a Retry-After in seconds."""
    assert r.status_code == 503, r.text
    assert r.headers["content-type"] == "application/problem+json"
    assert r.json()["code"] == "database_busy" and r.json()["status"] == 503
    assert int(r.headers["Retry-After"]) >= 1
    return True


def _connections(url: str, database: str, stop: threading.Event, seen: list[int]) -> None:
    """The server connections to ``database``, sampled until ``stop``."""
    engine = make_engine(url)
    try:
        with engine.connect() as c:
            while not stop.wait(0.05):
                query = "SELECT count(*) FROM pg_stat_activity WHERE datname = :db"
                seen.append(int(c.execute(text(query), {"db": database}).scalar_one()))
                c.rollback()
    finally:
        engine.dispose()


def test_a_burst_of_120_clients_on_2_instances_is_201_or_503(empty_postgres, tmp_path, monkeypatch):
    servers = [
        _serve(empty_postgres, tmp_path, monkeypatch, f"i{i}", RCB_DB_POOL_TIMEOUT="1")
        for i in range(INSTANCES)
    ]
    statuses: Counter[int] = Counter()
    acked: dict[str, int] = {}
    failures: list[str] = []
    lock = threading.Lock()
    stop, seen = threading.Event(), [0]
    try:
        plan_id, setpoints = _plan(servers[0])
        start = threading.Barrier(CLIENTS)
        deadline = time.monotonic() + DEADLINE_S

        def client(n: int) -> None:
            live = servers[n % INSTANCES]
            headers = {"Authorization": f"Bearer {live.keys['mes']}"}
            with httpx.Client(
                base_url=live.base, headers=headers, timeout=REQUEST_S, verify=LOOPBACK_TLS
            ) as c:
                start.wait()
                for k in range(REPORTS):
                    serial, key = f"S{n}-{k}", uuid.uuid4().hex
                    for _ in range(ATTEMPTS):
                        if time.monotonic() > deadline:
                            return
                        try:
                            r = c.post(
                                f"/plans/{plan_id}/parts",
                                json=report_at(serial, setpoints),
                                headers={"Idempotency-Key": key},
                            )
                        except httpx.HTTPError as err:  # a dropped connection
                            with lock:
                                failures.append(f"{serial}: {err!r}")
                            return
                        with lock:
                            statuses[r.status_code] += 1
                        if r.status_code != 503 or not _is_503(r):
                            break
                        time.sleep(int(r.headers["Retry-After"]))  # as a client should
                    if r.status_code == 201:
                        with lock:
                            acked[serial] = r.json()["part_id"]
                    else:
                        with lock:
                            failures.append(f"{serial}: {r.status_code} {r.text[:300]}")

        database = empty_postgres.rsplit("/", 1)[1]
        monitor = threading.Thread(target=_connections, args=(empty_postgres, database, stop, seen))
        monitor.start()
        threads = [threading.Thread(target=client, args=(n,)) for n in range(CLIENTS)]
        began = time.monotonic()
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(DEADLINE_S + REQUEST_S)
        took = time.monotonic() - began
    finally:
        stop.set()
        for live in servers:
            live.stop()
    print(f"{CLIENTS * REPORTS} reports in {took:.1f} s: {dict(statuses)}; peak {max(seen)} "
          "server connections")  # fmt: skip
    assert not failures, failures[:5]
    assert statuses[500] == 0 and set(statuses) <= {201, 503}
    assert len(acked) == CLIENTS * REPORTS  # every report answered 201 in the end
    assert max(seen) <= INSTANCES * WORKERS * Pool().connections() + 1  # + the monitor's own
    engine = make_engine(empty_postgres)
    with engine.connect() as c:
        rows = c.execute(text("SELECT serial, id FROM parts WHERE plan_id = :p"), {"p": plan_id})
        stored = Counter(serial for serial, _ in rows)
    engine.dispose()
    assert stored == Counter(list(acked))  # every 201 stored once, nothing else
    for live in servers:
        log = live.log.read_text()
        assert "Traceback" not in log and "too many clients" not in log


def test_a_request_that_finds_no_connection_in_time_is_503(empty_postgres, tmp_path, monkeypatch):
    """One connection per worker, held by a report waiting for the plan's row: the next is 503."""
    monkeypatch.setenv("RCB_DB_POOL_SIZE", "1")
    monkeypatch.setenv("RCB_DB_MAX_OVERFLOW", "0")
    monkeypatch.setenv("RCB_DB_POOL_TIMEOUT", "1")
    live = LiveServer(empty_postgres, tmp_path / "serve.log", workers=1)
    live.start()
    engine = make_engine(empty_postgres)
    try:
        plan_id, setpoints = _plan(live)
        first: list[httpx.Response] = []
        with engine.connect() as blocker, live.client("mes") as c:
            blocker.execute(text("SELECT id FROM plans WHERE id = :p FOR UPDATE"), {"p": plan_id})

            def post_first() -> None:
                body = report_at("A", setpoints)
                first.append(c.post(f"/plans/{plan_id}/parts", json=body,
                                    headers={"Idempotency-Key": "a"}))  # fmt: skip

            waiting = threading.Thread(target=post_first)
            waiting.start()
            _until_blocked(engine, blocker)
            body = report_at("B", setpoints)
            with live.client("mes") as other:
                busy = other.post(
                    f"/plans/{plan_id}/parts", json=body, headers={"Idempotency-Key": "b"}
                )
            assert _is_503(busy)
            blocker.rollback()  # the plan's row is free: the first report goes on
            waiting.join(30)
        assert first and first[0].status_code == 201, first
        with live.client("mes") as c:  # the retry of the refused report, same key: stored now
            retried = c.post(f"/plans/{plan_id}/parts", json=body, headers={"Idempotency-Key": "b"})
            assert retried.status_code == 201, retried.text
            serials = [p["serial"] for p in c.get(f"/plans/{plan_id}/parts").json()["items"]]
        assert sorted(serials) == ["A", "B"]
    finally:
        engine.dispose()
        live.stop()
    assert "Traceback" not in live.log.read_text()


def _until_blocked(engine: Any, blocker: Any, timeout_s: float = 30.0) -> None:
    """Wait until another connection waits for the lock ``blocker`` holds."""
    pid = blocker.execute(text("SELECT pg_backend_pid()")).scalar_one()
    deadline = time.monotonic() + timeout_s
    with engine.connect() as c:
        while time.monotonic() < deadline:
            query = "SELECT count(*) FROM pg_stat_activity WHERE :pid = ANY(pg_blocking_pids(pid))"
            if c.execute(text(query), {"pid": pid}).scalar_one():
                return
            c.rollback()
            time.sleep(0.05)
    pytest.fail("the first report never waited for the plan's row")


@pytest.mark.parametrize(
    ("variable", "value"),
    [("RCB_DB_POOL_SIZE", "0"), ("RCB_DB_MAX_OVERFLOW", "-1"), ("RCB_DB_POOL_TIMEOUT", "1.5")],
)
def test_a_malformed_pool_setting_is_one_line_naming_it(runner, tmp_path, variable, value):
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    result = runner.invoke(app, ["serve", "--db", url], env={variable: value})
    assert result.exit_code == 2 and f"{variable} = '{value}'" in result.stderr, result.output
    assert "Traceback" not in result.output


def test_which_database_errors_are_retry_later():
    def operational(message: str) -> OperationalError:
        return OperationalError("SELECT 1", {}, sqlite3.OperationalError(message))

    assert unavailable(PoolTimeoutError("QueuePool limit of size 1 overflow 0 reached"))
    assert unavailable(operational("database is locked"))
    assert not unavailable(operational("no such table: plans"))  # a bug, not a busy database
    assert not unavailable(ValueError("database is locked"))
    assert settings.pool({"RCB_DB_POOL_SIZE": "3"}) == Pool(size=3)
    assert Pool().connections() * 4 <= 100 - 3 - 20  # 4 workers, superusers', room for others
