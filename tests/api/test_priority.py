"""Writes first (issue 17 item 3): readers pause while a write is in flight, one long read at a
time per process, and a page rendered in the route's thread is the document FastAPI renders."""

from __future__ import annotations

import asyncio
import json
import threading
import time
from collections.abc import Iterator

import pytest
from test_service import BODY, _reports

from api.rest.rendering import page_response
from api.rest.schemas.parts import parse_report
from api.rest.schemas.review import History
from api.rest.writes_in_flight import WritesFirstMiddleware
from api.services import read as queries
from api.services.parts import report_part
from api.services.plans import create_plan
from api.services.writes_first import GATE, WritesFirst


def test_a_reader_waits_for_the_write_in_flight():
    gate = WritesFirst(max_wait_s=5.0)
    done = threading.Event()
    paused: list[float] = []

    def reader() -> None:
        begin = time.perf_counter()
        assert gate.pause()  # True: it went on because no write was left
        paused.append(time.perf_counter() - begin)
        done.set()

    with gate.writing():
        assert gate.writes == 1
        thread = threading.Thread(target=reader)
        thread.start()
        assert not done.wait(0.2)  # still waiting while the write is in flight
    thread.join(5)
    assert done.is_set() and gate.writes == 0
    assert 0.2 <= paused[0] < 5.0


def test_a_reader_is_slowed_never_starved():
    gate = WritesFirst(max_wait_s=0.05)
    with gate.writing():
        begin = time.perf_counter()
        assert gate.pause() is False  # gave up waiting: the write is still in flight
        assert 0.05 <= time.perf_counter() - begin < 2.0
    assert gate.pause() is True


def test_long_reads_run_one_at_a_time():
    gate = WritesFirst()
    inside, most, lock = [0], [0], threading.Lock()

    def read() -> None:
        with gate.reading():
            with lock:
                inside[0] += 1
                most[0] = max(most[0], inside[0])
            time.sleep(0.02)
            with lock:
                inside[0] -= 1

    threads = [threading.Thread(target=read) for _ in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10)
    assert most[0] == 1


def test_a_write_error_still_ends_the_write():
    gate = WritesFirst()
    with pytest.raises(RuntimeError), gate.writing():
        raise RuntimeError("the report failed")
    assert gate.writes == 0


def test_a_post_counts_as_a_write_only_once_its_body_is_in():
    """A lockout review: a POST whose body never finishes (no key, a stalled client) held every
    read at its pauses; it counts from its last body chunk to its answer, a GET never."""
    seen: list[tuple[str, int]] = []
    chunks: Iterator[dict] = iter([])

    async def receive() -> dict:
        return next(chunks)

    async def send(message: dict) -> None:
        seen.append(("sent", GATE.writes))

    async def app(scope, receive, send) -> None:
        seen.append(("arrived", GATE.writes))
        while (await receive()).get("more_body"):
            seen.append(("part of the body", GATE.writes))
        seen.append(("whole body", GATE.writes))
        await send({"type": "http.response.start", "status": 200, "headers": []})

    for method in ("POST", "GET"):
        chunks = iter(
            [
                {"type": "http.request", "body": b"{", "more_body": True},
                {"type": "http.request", "body": b"}", "more_body": False},
            ]
        )
        seen.clear()
        asyncio.run(WritesFirstMiddleware(app)({"type": "http", "method": method}, receive, send))
        writing = 1 if method == "POST" else 0
        assert seen == [
            ("arrived", 0),
            ("part of the body", 0),
            ("whole body", writing),
            ("sent", writing),
        ]
        assert GATE.writes == 0


def test_a_wait_must_be_positive():
    with pytest.raises(ValueError, match="max_wait_s"):
        WritesFirst(max_wait_s=0)


def test_a_history_page_renders_as_fastapi_renders_it(engine):
    bodies, _ = _reports(23)
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    for body in bodies:
        assert report_part(engine=engine, plan_id=plan_id, report=parse_report(body)).status == 201
    data = queries.plan_history(engine=engine, plan_id=plan_id, page_size=15)
    assert len(data["versions"]) == 15  # more than one chunk of rendering
    response = page_response(History, data, "versions")
    assert response.media_type == "application/json"
    expected = History.model_validate(data).model_dump_json().encode("utf-8")
    assert json.loads(response.body) == json.loads(expected)
    assert list(json.loads(response.body)) == list(json.loads(expected))  # key order too
