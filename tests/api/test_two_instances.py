"""Issue 33, item 4: two ``rcb serve`` instances on one database, one killed mid-load.

A plant group runs several instances on one database: on PostgreSQL through PgBouncer in
transaction pooling (a few server connections for every instance), or on one SQLite file.
Eight MES clients alternate between two instances, reporting parts of two plans at once, each
measurement different (so the order the reports are applied in changes the answers). After
some acknowledgements instance B is killed with ``kill -9``; a client whose request dies with
it sends the same report, same idempotency key, to instance A, as an MES with a fail-over
address does. Then:

- every report is acknowledged and stored once, under the part id its answer gave (a report B
  had stored before it died comes back from A as a replay of the stored answer);
- each plan's setpoint versions are contiguous and its idempotency keys stored once;
- bands, models, setpoints and decisions are those of replaying the same reports, in the order
  of their part ids, into one fresh database in process;
- B restarted serves the same setpoints as A, and every report sent again to either instance
  is answered with its stored answer;
- PostgreSQL never saw more server connections than PgBouncer's pool.

And a wrong-key burst spread over two instances is limited as one (the database's bucket,
:mod:`db.auth_buckets`), on each backend.
"""

from __future__ import annotations

import threading
import time
import tomllib
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import httpx
import pytest
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from api.rest.schemas.parts import parse_report
from api.services import read as queries
from api.services import throttle
from api.services.parts import report_part
from api.services.plans import create_plan
from db import tables as t
from db.engine import make_engine
from supervisor.rcb.state import RcbSettings

from conftest import DEMO_PLAN, _fresh_postgres, report_at, stored_state, without_ids
from live import LOOPBACK_TLS, LiveServer
from migrated import migrated
from pgbouncer_support import ConnectionPeak, pgbouncer

PLAN = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
PLANS, REPORTS, LANES, KILL_AFTER = 2, 120, 8, 60  # reports per plan; acks before the kill
SERVER_POOL = 4  # PgBouncer's server connections, shared by both instances' pools
TIMEOUT_S = 60.0
IN_FLIGHT_RETRIES = 100  # a fail-over may meet the key of the killed instance's request
WRONG = {"Authorization": "Bearer rcb_not-a-key"}


@dataclass(frozen=True)
class Shared:
    """The database both instances serve: their URL, and PostgreSQL's own (None: SQLite)."""

    url: str
    direct: str | None


@pytest.fixture(params=["sqlite", "postgres", "pgbouncer"])
def shared(request, tmp_path) -> Iterator[Shared]:
    if request.param == "sqlite":
        yield Shared(f"sqlite:///{tmp_path / 'rcb.db'}", None)
        return
    fresh = _fresh_postgres()
    direct = next(fresh)
    try:
        if request.param == "postgres":
            yield Shared(direct, direct)
        else:
            with pgbouncer(direct, tmp_path / "pgbouncer.log", SERVER_POOL) as url:
                yield Shared(url, direct)
    finally:
        next(fresh, None)


def _varied(serial: str, setpoints: dict[str, Any], k: int) -> dict[str, Any]:
    """A report made with ``setpoints``, every value 0.90-1.00 of its prediction (by ``k``):
    bands shrink and expand, 13 to 27 setpoint versions over 120 parts by the order."""
    report = report_at(serial, setpoints)
    factor = 0.9 + 0.1 * ((k * 37) % 23) / 22
    for operation in report["operations"]:
        for measured in operation["measurements"].values():
            measured["value"] *= factor
    return report


@dataclass(frozen=True)
class Report:
    plan: int  # index into the plans
    body: dict[str, Any]
    key: str


class Group:
    """Two instances and the clients' fail-over: a request whose instance is gone goes to the
    other, with the same body and key; a key still in flight there is asked again."""

    def __init__(self, servers: list[LiveServer]) -> None:
        self.servers = servers
        self.dead: set[int] = set()

    def clients(self) -> list[httpx.Client]:
        """One MES's clients, an address each, one API key for both (an idempotency key is
        the API key's: with another key a fail-over is 409, not the stored answer)."""
        mes = {"Authorization": f"Bearer {self.servers[0].keys['mes']}"}
        return [
            httpx.Client(base_url=s.base, headers=mes, timeout=60.0, verify=LOOPBACK_TLS)
            for s in self.servers
        ]

    def send(self, clients: list[httpx.Client], first: int, path: str, r: Report) -> httpx.Response:
        headers = {"Idempotency-Key": r.key}
        for _ in range(IN_FLIGHT_RETRIES):
            target = first if first not in self.dead else 1 - first
            try:
                answer = clients[target].post(path, json=r.body, headers=headers)
            except httpx.TransportError:
                self.dead.add(target)
                continue
            if answer.status_code != 409 or answer.json().get("code") != "in_flight":
                return answer
            time.sleep(0.1)
        raise AssertionError(f"{r.key}: no answer after {IN_FLIGHT_RETRIES} tries")


def _plans(server: LiveServer) -> tuple[list[int], list[dict[str, Any]]]:
    ids, setpoints = [], []
    with server.client("engineer") as c:
        for i in range(PLANS):
            created = c.post(
                "/plans", json={**PLAN, "name": f"two-{i}"}, params={"strategy": "ivester"}
            )
            assert created.status_code == 201, created.text
            ids.append(created.json()["id"])
            setpoints.append(c.get(f"/plans/{ids[-1]}/setpoints").json())
    return ids, setpoints


def _load(
    group: Group, plan_ids: list[int], reports: list[Report], peak: ConnectionPeak
) -> dict[int, httpx.Response]:
    """Eight lanes, each alternating between the instances; B killed after KILL_AFTER acks
    (``peak``'s next phase from there)."""
    answered: dict[int, httpx.Response] = {}
    mutex, enough = threading.Lock(), threading.Event()

    def lane(index: int) -> None:
        clients = group.clients()
        try:
            for j, i in enumerate(range(index, len(reports), LANES)):
                path = f"/plans/{plan_ids[reports[i].plan]}/parts"
                answer = group.send(clients, (index + j) % 2, path, reports[i])
                with mutex:
                    answered[i] = answer
                    if sum(a.status_code == 201 for a in answered.values()) >= KILL_AFTER:
                        enough.set()
        finally:
            for client in clients:
                client.close()

    with ThreadPoolExecutor(LANES) as pool:
        lanes = [pool.submit(lane, index) for index in range(LANES)]
        assert enough.wait(TIMEOUT_S * 2), "no acknowledgements before the kill"
        peak.phase()
        group.servers[1].kill()
        for running in lanes:
            running.result(timeout=TIMEOUT_S * 4)
    return answered


def _sent_again(group: Group, plan_ids: list[int], reports: list[Report]) -> list[Any]:
    """Every report sent again, alternately to each instance: (status, replayed, body)."""
    clients = group.clients()

    def send(i: int) -> tuple[int, str | None, Any]:
        r = reports[i]
        answer = clients[i % 2].post(
            f"/plans/{plan_ids[r.plan]}/parts", json=r.body, headers={"Idempotency-Key": r.key}
        )
        return answer.status_code, answer.headers.get("Idempotent-Replayed"), answer.json()

    try:
        with ThreadPoolExecutor(LANES) as pool:
            return list(pool.map(send, range(len(reports)), timeout=TIMEOUT_S * 2))
    finally:
        for client in clients:
            client.close()


def _stored(url: str, plan_id: int) -> tuple[dict[str, list[int]], list[int], list[int]]:
    """A plan's parts (serial -> ids), setpoint versions and its keys' record counts."""
    engine = make_engine(url)
    with Session(engine) as s:
        parts: dict[str, list[int]] = {}
        for serial, part_id in s.execute(
            select(t.Part.serial, t.Part.id).where(t.Part.plan_id == plan_id)
        ):
            parts.setdefault(serial, []).append(part_id)
        versions = s.scalars(
            select(t.SetpointVersion.version)
            .where(t.SetpointVersion.plan_id == plan_id)
            .order_by(t.SetpointVersion.version)
        ).all()
        keys = s.scalars(
            select(func.count())
            .select_from(t.IdempotencyRecord)
            .where(t.IdempotencyRecord.key.startswith(f"two-{plan_id}-"))
            .group_by(t.IdempotencyRecord.key)
        ).all()
    engine.dispose()
    return parts, list(versions), list(keys)


def _replayed(tmp_path, reports: list[list[Report]], order: list[list[int]]) -> Any:
    """The same reports, per plan in ``order``, into a fresh SQLite database in process."""
    url = f"sqlite:///{tmp_path / 'serial.db'}"
    migrated(url)
    engine = make_engine(url)
    answers, ids = [], []
    for i, (plan_reports, indices) in enumerate(zip(reports, order, strict=True)):
        body = {**PLAN, "name": f"two-{i}"}
        ids.append(
            create_plan(engine=engine, body=body, settings=RcbSettings("ivester")).body["id"]
        )
        answers.append(
            [
                report_part(
                    engine=engine, plan_id=ids[-1], report=parse_report(plan_reports[k].body)
                ).body
                for k in indices
            ]
        )
    return engine, ids, answers


@pytest.mark.parametrize("shared", ["sqlite", "pgbouncer"], indirect=True)
def test_two_instances_one_killed_store_each_part_once_as_a_serial_replay(shared, tmp_path):
    servers = [LiveServer(shared.url, tmp_path / f"serve{i}.log") for i in range(2)]
    pooled = "pgbouncer=" in shared.url
    for server in servers:
        server.start()
    try:
        plan_ids, setpoints = _plans(servers[0])
        per_plan = [
            [
                Report(p, _varied(f"P{p}-{k:03d}", setpoints[p], k), f"two-{plan_ids[p]}-{k}")
                for k in range(REPORTS)
            ]
            for p in range(PLANS)
        ]
        mixed = [per_plan[p][k] for k in range(REPORTS) for p in range(PLANS)]
        group = Group(servers)
        with ConnectionPeak(shared.direct if pooled else None) as connections:
            answered = _load(group, plan_ids, mixed, connections)
        assert group.dead == {1}, "B died mid-load, A never"
        assert [a.status_code for a in answered.values()] == [201] * len(mixed), [
            a.text for a in answered.values() if a.status_code != 201
        ]
        servers[1].start()  # same port, same database
        for plan_id in plan_ids:
            served = []
            for server in servers:
                with server.client("viewer") as client:
                    served.append(client.get(f"/plans/{plan_id}/setpoints").json())
            assert served[0] == served[1]
        again = _sent_again(group, plan_ids, mixed)
        assert again == [(201, "true", answered[i].json()) for i in range(len(mixed))]
        for server in servers:
            log = server.log.read_text(encoding="utf-8", errors="replace")
            assert "Traceback" not in log, log[-3000:]
    finally:
        for server in servers:
            server.stop()
    if pooled:
        # before the kill, PgBouncer's pool; after it, the server connections of the killed
        # instance's cut transactions linger (PgBouncer closes them and opens new ones; the
        # backends end a few ms later): at most one pool more, seen in 2 of 13 runs
        before, after = connections.peaks
        assert 0 < before <= SERVER_POOL and after <= 2 * SERVER_POOL, connections.peaks

    order: list[list[int]] = []
    for p, plan_id in enumerate(plan_ids):
        got = {mixed[i].body["serial"]: a.json() for i, a in answered.items() if mixed[i].plan == p}
        parts, versions, keys = _stored(shared.url, plan_id)
        assert parts == {serial: [a["part_id"]] for serial, a in got.items()}
        assert len(parts) == REPORTS and keys == [1] * REPORTS
        by_id = sorted(got.values(), key=lambda a: a["part_id"])
        assert versions == list(range(1, by_id[-1]["setpoint_version"] + 1))
        assert len(versions) > 2, "the reports moved the bands: their order matters"
        order.append([int(a["serial"].split("-")[1]) for a in by_id])

    serial, ids, replayed = _replayed(tmp_path, per_plan, order)
    engine = make_engine(shared.url)
    try:
        for p, plan_id in enumerate(plan_ids):
            got = sorted(
                (a.json() for i, a in answered.items() if mixed[i].plan == p),
                key=lambda a: a["part_id"],
            )
            assert [without_ids(a) for a in got] == [without_ids(a) for a in replayed[p]]
            assert stored_state(engine, plan_id) == stored_state(serial, ids[p])
            for read in (queries.full_history, queries.models_in_force, queries.get_plan):
                here = read(engine=engine, plan_id=plan_id)
                there = read(engine=serial, plan_id=ids[p])
                assert without_ids(here) == without_ids(there)
    finally:
        engine.dispose()
        serial.dispose()


def test_a_burst_spread_over_two_instances_is_limited_as_one(shared, tmp_path):
    """Before, each worker process kept its own bucket: a client had 60 wrong keys on each
    instance (120 before a 429). Now 60 over both, then 429 from either; another address
    still has its own."""
    servers = [LiveServer(shared.url, tmp_path / f"serve{i}.log") for i in range(2)]
    client_address = "127.0.0.11"
    for server in servers:
        server.start()
    try:
        clients = [
            httpx.Client(
                base_url=s.base,
                transport=httpx.HTTPTransport(local_address=client_address),
                headers=WRONG,
                timeout=30.0,
            )
            for s in servers
        ]
        burst, sent = throttle.BURST_FAILURES, throttle.BURST_FAILURES + 30
        started_s = time.monotonic()
        statuses = [clients[i % 2].get("/plans").status_code for i in range(sent)]
        earned = (time.monotonic() - started_s) * throttle.REFILL_PER_S  # while it lasted
        for client in clients:
            client.close()
        with servers[1].client(None, headers=WRONG) as other:
            assert other.get("/plans").status_code == 401
    finally:
        for server in servers:
            server.stop()
    # one bucket: 60 and what it earned back meanwhile (each instance's own: all 90 pass)
    assert statuses[:burst] == [401] * burst
    assert statuses.count(401) <= burst + earned + 1 and statuses.count(429) > 0, statuses
    engine = make_engine(shared.url)
    with Session(engine) as session:
        stored = session.scalars(select(t.AuthBucket.client)).all()
        audited = session.scalars(
            select(t.AuditEntry.detail).where(t.AuditEntry.result == "unauthenticated")
        ).all()
    engine.dispose()
    assert client_address in stored
    # the failures' audit: one row per window over both instances (db/audit_windows.py),
    # the counts whole after a clean stop (a minute's edge may split the burst in two rows)
    mine = [d for d in audited if d["client"] == client_address]
    assert len({d["window_start_s"] for d in mine}) == len(mine) <= 2, mine
    assert sum(d["count"] for d in mine) == sent
