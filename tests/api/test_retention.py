"""Issue 17, item 6: ``rcb db prune`` on SQLite and PostgreSQL, and the failure bookkeeping
of :mod:`api.services.throttle` (token bucket, coalesced audit rows) on a test clock."""

from __future__ import annotations

import json
from datetime import timedelta

from sqlalchemy import insert, select
from sqlalchemy.orm import Session

from api.cli.main import app
from api.services import auth
from api.services.throttle import FailureLimiter, FailureLog
from db import audit, idempotency
from db import tables as t

from conftest import engine_url

#: Ages of the stored rows.
AUDIT_AGES = {"older than a year": timedelta(days=400), "a quarter": timedelta(days=90)}
IDEMPOTENCY_AGES = {
    "a week and a day": timedelta(days=8),
    "two days": timedelta(days=2),
    "23 hours": timedelta(hours=23),
}


def _seed(engine) -> None:
    now = t.utcnow()
    with Session(engine) as session, session.begin():
        for what, age in AUDIT_AGES.items():
            row = audit.audit_row("cli", "test", what, "ok")
            session.execute(insert(audit.AUDIT), {**row, "at": now - age})
        for what, age in IDEMPOTENCY_AGES.items():
            row = idempotency.idempotency_row(None, what, "0" * 64, 201, {"ok": True})
            session.execute(insert(idempotency.IDEMPOTENCY), {**row, "created_at": now - age})


def _left(engine) -> tuple[set[str], set[str]]:
    with Session(engine) as session:
        audit = set(
            session.scalars(select(t.AuditEntry.target).where(t.AuditEntry.action == "test"))
        )
        keys = set(session.scalars(select(t.IdempotencyRecord.key)))
    return audit, keys


def test_prune_deletes_what_is_older_and_keeps_a_day_of_idempotency(runner, engine):
    """Before: no ``rcb db prune``; audit_log and idempotency_records grew for ever."""
    _seed(engine)
    url = engine_url(engine)
    refused = runner.invoke(app, ["db", "prune", "--idempotency-older-than", "23h", "--db", url])
    assert refused.exit_code == 2 and "Traceback" not in refused.stderr
    assert "--idempotency-older-than = '23h'" in refused.stderr
    assert "at least 24h" in refused.stderr
    assert _left(engine) == (set(AUDIT_AGES), set(IDEMPOTENCY_AGES))  # nothing deleted

    pruned = runner.invoke(app, ["db", "prune", "--db", url])  # 365d and 7d
    assert pruned.exit_code == 0, pruned.output
    told = " ".join(pruned.stderr.split())
    assert "deleted 1 audit entries older than 365d, 1 idempotency records older than 7d" in told
    assert _left(engine) == ({"a quarter"}, {"two days", "23 hours"})

    args = ["db", "prune", "--audit-older-than", "30d", "--idempotency-older-than", "24h"]
    again = runner.invoke(app, [*args, "--db", url, "--json"])
    assert again.exit_code == 0, again.output
    counts = json.loads(again.stdout)
    assert (counts["audit_log"], counts["idempotency_records"]) == (1, 1)
    assert _left(engine) == (set(), {"23 hours"})
    with Session(engine) as session:  # the prunes are audited themselves
        prunes = session.scalars(select(t.AuditEntry).where(t.AuditEntry.action == "prune"))
        assert [p.detail for p in prunes] == [
            {"audit_log": 1, "idempotency_records": 1, "band_states": 0},
            {"audit_log": 1, "idempotency_records": 1, "band_states": 0},
        ]


def test_prune_refuses_a_malformed_age_naming_the_option(runner, tmp_path):
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    for option, value in (("--audit-older-than", "1y"), ("--audit-older-than", "0d"),
                          ("--idempotency-older-than", "99999999d"),
                          ("--states-older-than", "0d")):  # fmt: skip
        r = runner.invoke(app, ["db", "prune", option, value, "--db", url])
        assert r.exit_code == 2 and f"{option} = '{value}'" in r.stderr, r.stderr
        assert len(r.stderr.strip().splitlines()) == 1


class Clock:
    """A test clock [s]."""

    def __init__(self) -> None:
        self.now_s = 1000.0

    def __call__(self) -> float:
        return self.now_s


def test_the_bucket_refuses_after_the_burst_and_earns_back_one_per_second():
    clock = Clock()
    limiter = FailureLimiter(burst=3, refill_per_s=0.5, clock=clock)
    assert [limiter.spend("a") for _ in range(4)] == [0, 0, 0, 2]  # 1 token takes 2 s
    assert limiter.spend("b") == 0  # another address has its own bucket
    clock.now_s += 2.0
    assert limiter.spend("a") == 0 and limiter.spend("a") == 2
    clock.now_s += 100.0  # a long pause refills at most the burst
    assert [limiter.spend("a") for _ in range(4)] == [0, 0, 0, 2]


def test_failures_are_one_row_per_window_with_their_count():
    clock = Clock()
    clock.now_s = 600.0  # a window's start
    log = FailureLog(window_s=60.0, flush_s=2.0, clock=clock)
    rows: dict[tuple, int] = {}  # the shared counts (db.audit_windows), per window

    def add(client, action, reason, start_s, window_s, delta) -> None:
        assert window_s == 60.0
        key = (client, action, reason, start_s)
        rows[key] = rows.get(key, 0) + delta

    first = ("10.0.0.9", "GET /plans", "no key", 600.0)
    for _ in range(100):  # 100 failures in 10 s: one row, its count written every 2 s
        log.record("10.0.0.9", "GET /plans", "no key", add)
        clock.now_s += 0.1
    assert list(rows) == [first] and 80 <= rows[first] < 100  # lags by at most 2 s
    log.record("10.0.0.9", "GET /plans", "unknown or revoked key", add)
    assert len(rows) == 2  # another reason: its own row, written at its first failure
    clock.now_s = 661.0  # the next window: the first row's count is completed, a new row
    log.record("10.0.0.9", "GET /plans", "no key", add)
    assert rows[first] == 100 and rows[(*first[:3], 660.0)] == 1 and len(rows) == 3


def test_a_pruned_window_row_is_written_again(engine):
    """A coalesced row deleted by a prune mid-window comes back, with the window's count."""
    clock = Clock()
    clock.now_s = 600.0
    auth._failures[engine] = FailureLog(window_s=60.0, flush_s=2.0, clock=clock)
    for _ in range(2):
        assert (
            auth.authenticate(engine=engine, key=None, action="GET /x", client="10.1.1.1") is None
        )
    with Session(engine) as session, session.begin():
        session.execute(t.core_table(t.AuditEntry).delete())
    clock.now_s += 3.0  # the next failure writes its count
    auth.authenticate(engine=engine, key=None, action="GET /x", client="10.1.1.1")
    with Session(engine) as session:
        details = session.scalars(select(t.AuditEntry.detail)).all()
    assert [(d["client"], d["reason"], d["count"]) for d in details] == [("10.1.1.1", "no key", 3)]
