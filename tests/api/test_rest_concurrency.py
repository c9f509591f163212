"""Many MES clients at once, and a ``kill -9`` mid-stream, against a real ``rcb serve``.

Every report here carries the same measurements (the predictions of setpoint version 1; only
the serial differs), so every serial order of applying them gives the same answers. The
answers sorted by part id must therefore equal a one-by-one run in process (``reference``):
that is what "the concurrent reports were serialised, nothing lost or applied twice" means.
"""

from __future__ import annotations

import json
import threading
import time
import tomllib
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import httpx
import pytest
from sqlalchemy import func, select, text
from sqlalchemy.orm import Session

from api.rest.schemas.parts import parse_report
from api.services import read as queries
from api.services.parts import report_part
from api.services.plans import create_plan
from db import tables as t
from db.engine import make_engine
from supervisor.rcb.state import RcbSettings

from conftest import DEMO_PLAN, report_at
from live import LiveServer
from migrated import migrated

PLAN = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
DECISIONS_PER_PART = 2 * len(PLAN["operations"])  # force_N and roughness_um on 6 operations
CLIENTS = 50  # concurrent reporters of distinct parts
SAME_KEY_CLIENTS, SAME_KEY_ROUNDS = 10, 3
STREAM, LANES, KILL_AFTER = 200, 8, 40  # crash test: reports, client threads, acks before kill
KILLS = 2  # crash test: kill -9 and restart, twice
TIMEOUT_S = 60.0
IN_FLIGHT_RETRIES = 50  # a replay may meet the key of a dying request of the killed server


def _post(client: httpx.Client, plan_id: int, body: dict, key: str) -> httpx.Response:
    return client.post(f"/plans/{plan_id}/parts", json=body, headers={"Idempotency-Key": key})


def _outcome(answer: dict[str, Any]) -> dict[str, Any]:
    """A 201 body without what differs from part to part (id, serial), as JSON gives it."""
    rest = {k: v for k, v in answer.items() if k not in ("part_id", "serial")}
    return json.loads(json.dumps(rest))


def _new_plan(live: LiveServer) -> tuple[int, dict[str, Any]]:
    """A demo plan on the server and its setpoints (version 1)."""
    with live.client("engineer") as c:
        created = c.post("/plans", json=PLAN, params={"strategy": "ivester"})
        assert created.status_code == 201, created.text
        plan_id = created.json()["id"]
        setpoints = c.get(f"/plans/{plan_id}/setpoints")
        assert setpoints.status_code == 200, setpoints.text
    return plan_id, setpoints.json()


@dataclass(frozen=True)
class Reference:
    """The first report (serial "") and the answers of ``STREAM`` reports made one by one."""

    report: dict[str, Any]
    answers: list[dict[str, Any]]


@dataclass(frozen=True)
class Stored:
    """What the database holds for one plan, read directly (not through the service)."""

    parts: dict[str, list[int]]  # serial -> part ids
    decisions: int
    measurements: int
    band_states: int
    versions: list[tuple[int, str, int | None]]  # (version, cause, part_id), by version
    current_version: int
    idempotency_keys: dict[str, int]  # key -> records
    integrity: str


def _stored(url: str, plan_id: int, key_prefix: str = "") -> Stored:
    engine = make_engine(url)
    try:
        with Session(engine) as s:
            part_ids = select(t.Part.id).where(t.Part.plan_id == plan_id).scalar_subquery()

            def count(table: Any) -> int:
                query = select(func.count()).select_from(table)
                return s.scalar(query.where(table.part_id.in_(part_ids))) or 0

            parts: dict[str, list[int]] = {}
            for serial, part_id in s.execute(
                select(t.Part.serial, t.Part.id).where(t.Part.plan_id == plan_id)
            ):
                parts.setdefault(serial, []).append(part_id)
            version = t.SetpointVersion
            versions = s.execute(
                select(version.version, version.cause, version.part_id)
                .where(version.plan_id == plan_id)
                .order_by(version.version)
            ).all()
            record = t.IdempotencyRecord
            keys = s.execute(
                select(record.key, func.count())
                .where(record.key.startswith(key_prefix))
                .group_by(record.key)
            ).all()
            sqlite = engine.dialect.name == "sqlite"
            return Stored(
                parts=parts,
                decisions=count(t.RcbDecision),
                measurements=count(t.Measurement),
                band_states=count(t.BandState),
                versions=[tuple(v) for v in versions],
                current_version=s.get(t.Plan, plan_id).current_setpoint_version,
                idempotency_keys=dict(keys),
                integrity=s.scalar(text("PRAGMA integrity_check")) if sqlite else "ok",
            )
    finally:
        engine.dispose()


def _check_serialised(stored: Stored, answers: dict[str, dict], reference: Reference) -> None:
    """The database and the 201 answers are those of applying the parts one after another."""
    n = len(answers)
    assert stored.parts == {serial: [answer["part_id"]] for serial, answer in answers.items()}, (
        "every reported part stored exactly once, with the id its answer gave"
    )
    in_order = sorted(answers.values(), key=lambda answer: answer["part_id"])
    assert [_outcome(a) for a in in_order] == reference.answers[:n]
    assert stored.decisions == stored.measurements == stored.band_states == n * DECISIONS_PER_PART
    # a new setpoint version for, and only for, each part that moved a band: 1..V, no gaps
    created, last = [], 1
    for answer in in_order:
        if answer["setpoint_version"] != last:
            last = answer["setpoint_version"]
            created.append((last, "part", answer["part_id"]))
    assert stored.versions == [(1, "initial", None), *created]
    assert [v[0] for v in stored.versions] == list(range(1, stored.current_version + 1))
    assert stored.current_version == reference.answers[n - 1]["setpoint_version"]
    assert stored.integrity == "ok"


def _start(live: LiveServer) -> None:
    """Start the server and wait until every worker process has started, not only the first."""
    live.start()
    deadline = time.monotonic() + TIMEOUT_S
    while time.monotonic() < deadline:
        log = live.log.read_text(encoding="utf-8", errors="replace")
        if log.count("Application startup complete.") >= live.workers:
            return
        time.sleep(0.1)
    raise AssertionError(f"not all {live.workers} workers started: {log[-3000:]}")


def _check_log(live: LiveServer) -> None:
    log = live.log.read_text(encoding="utf-8", errors="replace")
    assert "locked" not in log.lower(), log[-3000:]
    assert "Traceback" not in log, log[-3000:]


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Reference:
    url = f"sqlite:///{tmp_path_factory.mktemp('reference') / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    try:
        plan_id = create_plan(engine=engine, body=PLAN, settings=RcbSettings("ivester")).body["id"]
        setpoints = queries.current_setpoints(engine=engine, plan_id=plan_id)
        answers = [
            report_part(
                engine=engine,
                plan_id=plan_id,
                report=parse_report(report_at(f"REF-{i}", setpoints)),
            ).body
            for i in range(STREAM)
        ]
    finally:
        engine.dispose()
    return Reference(report_at("", setpoints), [_outcome(a) for a in answers])


def test_reference_moves_bands_then_holds(reference):
    """The stream is a real test of serialisation: its first parts change the setpoints."""
    versions = [a["setpoint_version"] for a in reference.answers]
    assert versions[0] == 2 and versions == sorted(versions) and versions[-1] > 2
    actions = {u["action"] for a in reference.answers[-10:] for u in a["updates"]}
    assert actions == {"hold"}  # later parts, all made at version 1, move nothing


@pytest.mark.parametrize("workers", [1, 2])
def test_fifty_clients_report_distinct_parts_at_once(backend_url, tmp_path, reference, workers):
    live = LiveServer(backend_url, tmp_path / "serve.log", workers=workers)
    _start(live)
    try:
        plan_id, setpoints = _new_plan(live)
        assert report_at("", setpoints) == reference.report
        barrier = threading.Barrier(CLIENTS, timeout=TIMEOUT_S)

        def send(i: int) -> httpx.Response:
            body = report_at(f"C{i:02d}", setpoints)  # all made with version 1: allowed
            with live.client("mes") as client:
                barrier.wait()
                return _post(client, plan_id, body, f"c-{plan_id}-{i}")

        with ThreadPoolExecutor(CLIENTS) as pool:
            responses = list(pool.map(send, range(CLIENTS), timeout=2 * TIMEOUT_S))

        statuses = Counter(r.status_code for r in responses)
        assert statuses == {201: CLIENTS}, [r.text for r in responses if r.status_code != 201]
        assert not any("Idempotent-Replayed" in r.headers for r in responses)
        answers = {r.json()["serial"]: r.json() for r in responses}
        assert sorted(answers) == [f"C{i:02d}" for i in range(CLIENTS)]
        stored = _stored(live.url, plan_id, f"c-{plan_id}-")
        _check_serialised(stored, answers, reference)
        assert stored.idempotency_keys == {f"c-{plan_id}-{i}": 1 for i in range(CLIENTS)}
        _check_log(live)
    finally:
        live.stop()


def test_same_key_at_once_stores_one_part(backend_url, tmp_path):
    # two worker processes: the copies of a request meet in one process and across processes
    live = LiveServer(backend_url, tmp_path / "serve.log", workers=2)
    _start(live)
    try:
        plan_id, setpoints = _new_plan(live)
        for round_ in range(SAME_KEY_ROUNDS):
            body, key = report_at(f"K{round_}", setpoints), f"k-{plan_id}-{round_}"
            barrier = threading.Barrier(SAME_KEY_CLIENTS, timeout=TIMEOUT_S)

            def send(_: int, body=body, key=key, barrier=barrier) -> httpx.Response:
                with live.client("mes") as client:
                    barrier.wait()
                    return _post(client, plan_id, body, key)

            with ThreadPoolExecutor(SAME_KEY_CLIENTS) as pool:
                responses = list(pool.map(send, range(SAME_KEY_CLIENTS), timeout=2 * TIMEOUT_S))

            created = [r for r in responses if r.status_code == 201]
            refused = [r for r in responses if r.status_code != 201]
            assert all(r.status_code == 409 and r.json()["code"] == "in_flight" for r in refused), [
                r.text for r in refused
            ]
            assert created and all(r.json() == created[0].json() for r in created)
            fresh = [r for r in created if "Idempotent-Replayed" not in r.headers]
            assert len(fresh) == 1, "exactly one request did the work"
            assert all(
                r.headers.get("Idempotent-Replayed") == "true" for r in created if r not in fresh
            )
            with live.client("mes") as client:  # the key is not left in flight
                again = _post(client, plan_id, body, key)
            assert again.status_code == 201 and again.headers["Idempotent-Replayed"] == "true"
            assert again.json() == created[0].json()

        stored = _stored(live.url, plan_id, f"k-{plan_id}-")
        assert {s: len(ids) for s, ids in stored.parts.items()} == {
            f"K{i}": 1 for i in range(SAME_KEY_ROUNDS)
        }
        assert stored.decisions == SAME_KEY_ROUNDS * DECISIONS_PER_PART
        assert stored.idempotency_keys == {f"k-{plan_id}-{i}": 1 for i in range(SAME_KEY_ROUNDS)}
        _check_log(live)
    finally:
        live.stop()


def test_kill_9_mid_stream_then_replay_keeps_every_acknowledged_part_once(
    backend_url, tmp_path, reference
):
    live = LiveServer(backend_url, tmp_path / "serve.log")
    live.start()
    try:
        plan_id, setpoints = _new_plan(live)
        reports = [(report_at(f"S{i:03d}", setpoints), f"s-{plan_id}-{i}") for i in range(STREAM)]
        answered: dict[int, httpx.Response] = {}
        mutex = threading.Lock()

        def stream(lane: int, pending: list[int], target: int, enough: threading.Event) -> None:
            with live.client("mes") as client:
                for i in pending[lane::LANES]:
                    try:
                        r = _post(client, plan_id, *reports[i])
                    except httpx.TransportError:
                        return  # the server is gone: this lane's other reports are unsent
                    with mutex:
                        answered[i] = r
                        if sum(a.status_code == 201 for a in answered.values()) >= target:
                            enough.set()

        for kill in range(1, KILLS + 1):  # stream, kill -9 mid-stream, restart; twice
            # the second stream sends what the first left unanswered (some of it stored before
            # the kill: those come back as replays of the stored answer)
            pending = [i for i in range(STREAM) if i not in answered]
            enough = threading.Event()
            with ThreadPoolExecutor(LANES) as pool:
                lanes = [
                    pool.submit(stream, lane, pending, kill * KILL_AFTER, enough)
                    for lane in range(LANES)
                ]
                assert enough.wait(TIMEOUT_S), f"no acknowledgements before kill {kill}"
                live.kill()
                for lane in lanes:
                    lane.result(timeout=TIMEOUT_S)
            assert all(r.status_code == 201 for r in answered.values()), [
                r.text for r in answered.values() if r.status_code != 201
            ]
            acked = {i: r.json() for i, r in answered.items()}
            assert kill * KILL_AFTER <= len(acked) < STREAM, "each kill came mid-stream"

            live.start()  # same port, same database
            # read after the restart, when nothing writes until the next stream (a COMMIT the
            # killed server had already sent to PostgreSQL may land just after the kill)
            before = _stored(live.url, plan_id)
            assert {reports[i][0]["serial"] for i in acked} <= set(before.parts)
            assert all(before.parts[a["serial"]] == [a["part_id"]] for a in acked.values())

        def replay(lane: int) -> dict[int, httpx.Response]:
            got = {}
            with live.client("mes") as client:
                for i in range(lane, STREAM, LANES):
                    for _ in range(IN_FLIGHT_RETRIES):
                        r = _post(client, plan_id, *reports[i])
                        if r.status_code != 409 or r.json().get("code") != "in_flight":
                            break
                        time.sleep(0.2)
                    got[i] = r
            return got

        with ThreadPoolExecutor(LANES) as pool:
            replayed: dict[int, httpx.Response] = {}
            for got in pool.map(replay, range(LANES), timeout=2 * TIMEOUT_S):
                replayed.update(got)

        assert sorted(replayed) == list(range(STREAM))
        assert all(r.status_code == 201 for r in replayed.values()), [
            r.text for r in replayed.values() if r.status_code != 201
        ]
        for i, answer in acked.items():
            assert replayed[i].headers.get("Idempotent-Replayed") == "true"
            assert replayed[i].json() == answer
        for i in set(range(STREAM)) - set(acked):  # unanswered: stored before the kill or not
            was_stored = reports[i][0]["serial"] in before.parts
            assert (replayed[i].headers.get("Idempotent-Replayed") == "true") == was_stored

        answers = {r.json()["serial"]: r.json() for r in replayed.values()}
        stored = _stored(live.url, plan_id, f"s-{plan_id}-")
        _check_serialised(stored, answers, reference)
        assert stored.idempotency_keys == {key: 1 for _, key in reports}
        _check_log(live)
    finally:
        live.stop()


def test_plans_for_a_new_machine_created_at_once_all_succeed(backend_url, tmp_path):
    # found by benchmarks/api_load.py: 7 of 8 simultaneous plans for a machine and tools not
    # yet stored got 409 (the race to insert them); the loser now retries and finds them
    server = LiveServer(backend_url, tmp_path / "serve.log", workers=2)
    server.start()
    try:
        barrier = threading.Barrier(8)

        def create(i: int) -> httpx.Response:
            with server.client("engineer") as c:
                barrier.wait(timeout=TIMEOUT_S)
                return c.post("/plans", json={**PLAN, "name": f"race-{i}"})

        with ThreadPoolExecutor(8) as pool:
            answers = list(pool.map(create, range(8)))
        assert [r.status_code for r in answers] == [201] * 8, [r.text for r in answers]
        engine = make_engine(backend_url)
        with Session(engine) as session:
            assert session.scalar(select(func.count()).select_from(t.Machine)) == 1
            assert session.scalar(select(func.count()).select_from(t.Plan)) == 8
        engine.dispose()
    finally:
        server.stop()
