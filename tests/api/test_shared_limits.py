"""Issue 33, item 2: the wrong-key limit is one for every instance on the database.

Two real ``rcb serve`` instances on one database (a SQLite file, a PostgreSQL database); a
client sends wrong keys to each in turn. Before, each worker process kept its own bucket: the
client had 60 wrong keys on each instance (120 before a 429). Now the bucket is the
database's (``db/auth_buckets.py``): 60 over both, then 429 from either, and another address
still has its own.
"""

from __future__ import annotations

import httpx
from sqlalchemy import select
from sqlalchemy.orm import Session

from api.services import throttle
from db import tables as t
from db.engine import make_engine

from live import LiveServer

CLIENT = "127.0.0.11"
WRONG = {"Authorization": "Bearer rcb_not-a-key"}


def test_a_burst_spread_over_two_instances_is_limited_as_one(backend_url, tmp_path):
    servers = [LiveServer(backend_url, tmp_path / f"serve{i}.log") for i in range(2)]
    for server in servers:
        server.start()
    try:
        transport = [httpx.HTTPTransport(local_address=CLIENT) for _ in servers]
        clients = [
            httpx.Client(base_url=s.base, transport=tr, headers=WRONG, timeout=30.0)
            for s, tr in zip(servers, transport, strict=True)
        ]
        burst = throttle.BURST_FAILURES
        statuses = [clients[i % 2].get("/plans").status_code for i in range(burst + 10)]
        for client in clients:
            client.close()
        # another address is not limited by this one's failures, on either instance
        with servers[1].client(None, headers=WRONG) as other:
            assert other.get("/plans").status_code == 401
    finally:
        for server in servers:
            server.stop()
    # a second's refill may let one more through while the burst lasts
    assert statuses[:burst] == [401] * burst
    assert statuses[burst:].count(429) >= 9, statuses[burst:]
    engine = make_engine(backend_url)
    with Session(engine) as session:
        stored = session.scalars(select(t.AuthBucket.client)).all()
    engine.dispose()
    assert CLIENT in stored
