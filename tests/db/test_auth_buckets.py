"""The shared wrong-key buckets (db/auth_buckets.py) on SQLite and PostgreSQL, by hand.

Period T = 2 s, burst 3 (tolerance τ = 2 T = 4 s): at t = 1000 three failures pass (the
time moves 1002, 1004, 1006) and the fourth is refused at 1006 (1006 − 1000 > 4); two
seconds later one more passes; a bucket whose time has passed is pruned (it is full).
And the audit windows of failures (db/audit_windows.py), counted over two processes.
"""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import Session

from api.services.throttle import FailureLimiter, FailureLog
from db import audit_windows, auth_buckets
from db import tables as t

PERIOD, TOLERANCE = 2.0, 4.0


def _spend(engine, client, now):
    with Session(engine) as session, session.begin():
        return auth_buckets.spend(
            session=session, client=client, now_s=now, period_s=PERIOD, tolerance_s=TOLERANCE
        )


def test_the_bucket_allows_the_burst_then_one_per_period(engine):
    assert [_spend(engine, "a", 1000.0) for _ in range(4)] == [None, None, None, 1006.0]
    assert _spend(engine, "b", 1000.0) is None  # another address, its own row
    assert _spend(engine, "a", 1002.0) is None and _spend(engine, "a", 1002.0) == 1008.0
    with Session(engine) as session, session.begin():
        assert auth_buckets.prune(session=session, now_s=1007.0) == 1  # b (1002): full again
        assert auth_buckets.prune(session=session, now_s=1007.0) == 0


def test_two_limiters_on_one_database_share_the_burst(engine):
    """Two processes' limiters (a clock each, the same time): three failures over both."""
    now = [1000.0]

    def shared(client, now_s, period_s, tolerance_s):
        with Session(engine) as session, session.begin():
            return auth_buckets.spend(
                session=session, client=client, now_s=now_s, period_s=period_s,
                tolerance_s=tolerance_s,
            )  # fmt: skip

    first, second = (FailureLimiter(burst=3, refill_per_s=0.5, clock=lambda: now[0]) for _ in "ab")
    waits = [(first, second)[i % 2].spend("c", shared) for i in range(4)]
    assert waits == [0, 0, 0, 2]  # alone, each would have allowed all four
    # the refusal is remembered where it came (the second): its next refusal asks nothing
    assert second.spend("c", lambda *_: (_ for _ in ()).throw(AssertionError("asked"))) == 2


def test_two_processes_count_one_audit_window(engine):
    """Two processes' failure logs on one database (db/audit_windows.py): one audit row per
    window with the sum of both counts; a row pruned meanwhile comes back with the sum."""
    now = [600.0]
    logs = [FailureLog(window_s=60.0, flush_s=2.0, clock=lambda: now[0]) for _ in "ab"]

    def add(client, action, reason, start_s, window_s, delta):
        with Session(engine) as session, session.begin():
            audit_windows.add(
                session=session, client=client, action=action, reason=reason,
                start_s=start_s, window_s=window_s, delta=delta,
            )  # fmt: skip

    for i in range(30):  # 30 failures over both in 3 s, then both flush
        logs[i % 2].record("10.0.0.7", "GET /plans", "no key", add)
        now[0] += 0.1
    assert [log.flush(add) for log in logs] == [1, 1]
    assert _windows(engine) == [(600.0, 30)]
    with Session(engine) as session, session.begin():
        session.execute(t.core_table(t.AuditEntry).delete())
    logs[0].record("10.0.0.7", "GET /plans", "no key", add)
    logs[0].flush(add)
    assert _windows(engine) == [(600.0, 31)]  # the window's whole count, not the process's
    now[0] = 665.0  # the next window: its own row; the ended one is pruned, its row stays
    logs[1].record("10.0.0.7", "GET /plans", "no key", add)
    with Session(engine) as session, session.begin():
        assert audit_windows.prune(session=session, before_s=660.0) == 1
    assert _windows(engine) == [(600.0, 31), (660.0, 1)]


def _windows(engine):
    """The audit rows of authentication failures: (window start, count), oldest first."""
    with Session(engine) as session:
        rows = session.scalars(select(t.AuditEntry.detail).order_by(t.AuditEntry.id)).all()
    return [(d["window_start_s"], d["count"]) for d in rows]
