"""The shared wrong-key buckets (db/auth_buckets.py) on SQLite and PostgreSQL, by hand.

Period T = 2 s, burst 3 (tolerance τ = 2 T = 4 s): at t = 1000 three failures pass (the
time moves 1002, 1004, 1006) and the fourth is refused at 1006 (1006 − 1000 > 4); two
seconds later one more passes; a bucket whose time has passed is pruned (it is full).
"""

from __future__ import annotations

from sqlalchemy.orm import Session

from api.services.throttle import FailureLimiter
from db import auth_buckets

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
