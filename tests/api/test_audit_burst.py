"""A burst of authentication failures is counted whole in the audit log (issue 29, item 6).

Before: 100 wrong-key and 100 no-key requests in about a second were stored as count 1 each,
still 1 after a minute idle and after a clean SIGTERM: a coalesced row's count was written only
when a later failure came more than 2 s after the last write. Now the counts are written on a
timer and at shutdown (api/rest/lifespan.py).
"""

from __future__ import annotations

import time

import httpx
from sqlalchemy import select
from sqlalchemy.orm import Session

from api.services import throttle
from db import tables as t
from db.engine import make_engine

from live import LiveServer

BURST = 100
#: The address the burst comes from (Linux routes all of 127.0.0.0/8 to the loopback).
CLIENT = "127.0.0.9"


def _counts(url: str) -> dict[str, int]:
    """The counted failures of :data:`CLIENT` per reason, summed over its windows."""
    engine = make_engine(url)
    try:
        with Session(engine) as session:
            query = select(t.AuditEntry).where(t.AuditEntry.result == "unauthenticated")
            counts: dict[str, int] = {}
            for row in session.scalars(query):
                if (row.detail or {}).get("client") == CLIENT:
                    reason = row.detail["reason"]
                    counts[reason] = counts.get(reason, 0) + row.detail["count"]
            return counts
    finally:
        engine.dispose()


def _burst(server: LiveServer) -> list[int]:
    """100 wrong-key and 100 no-key requests, interleaved, one after another."""
    transport = httpx.HTTPTransport(local_address=CLIENT)
    statuses = []
    with httpx.Client(base_url=server.base, transport=transport, timeout=30.0) as client:
        for _ in range(BURST):
            wrong = client.get("/plans", headers={"Authorization": "Bearer rcb_not-a-key"})
            statuses += [wrong.status_code, client.get("/plans").status_code]
    return statuses


def test_a_burst_is_counted_whole_after_a_clean_stop(backend_url, tmp_path):
    server = LiveServer(backend_url, tmp_path / "serve.log", workers=2)
    server.start()
    try:
        started_s = time.monotonic()
        statuses = _burst(server)
        print(f"burst of {2 * BURST} failures in {time.monotonic() - started_s:.2f} s")
    finally:
        server.stop()  # SIGTERM: the workers write their counts as they shut down
    assert statuses.count(401) + statuses.count(429) == 2 * BURST
    assert statuses.count(429) >= BURST - 2 * throttle.BURST_FAILURES  # both workers' buckets
    assert _counts(backend_url) == {"unknown or revoked key": BURST, "no key": BURST}
    assert "Traceback" not in server.log.read_text()


def test_a_burst_is_counted_whole_on_the_timer_while_serving(sqlite_server):
    """Nothing follows the burst and the server keeps running: the timer writes the counts."""
    statuses = _burst(sqlite_server)
    assert set(statuses) <= {401, 429}
    deadline = time.monotonic() + 4 * throttle.FLUSH_S + 5.0  # the timer's period and slack
    while _counts(sqlite_server.url) != {"unknown or revoked key": BURST, "no key": BURST}:
        assert time.monotonic() < deadline, _counts(sqlite_server.url)
        time.sleep(0.2)
