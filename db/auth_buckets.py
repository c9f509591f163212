"""The wrong-key allowance of each client address, shared by every instance on the database.

One row per client address: the generic cell rate algorithm's theoretical arrival time
(:class:`api.services.throttle.FailureLimiter` explains it). :func:`spend` allows and moves it
in one statement (an upsert whose update holds only while the client has failures left), so
two instances spending at once are serialised by the row and never both spend the last
failure. A row whose time has passed is a full bucket: :func:`prune` deletes them.
"""

from __future__ import annotations

from sqlalchemy import delete, select, text
from sqlalchemy.orm import Session

from db import tables as t

#: The upsert, per dialect (PostgreSQL's GREATEST is SQLite's two-argument MAX).
_SPEND = """
INSERT INTO auth_buckets (client, tat_s) VALUES (:client, :now + :period)
ON CONFLICT (client) DO UPDATE SET tat_s = {high}(auth_buckets.tat_s, :now) + :period
WHERE {high}(auth_buckets.tat_s, :now) - :now <= :tolerance
RETURNING tat_s
"""


def spend(
    *, session: Session, client: str, now_s: float, period_s: float, tolerance_s: float
) -> float | None:
    """Spend one failure of ``client`` at ``now_s``: None if allowed, else its time [s]."""
    high = "GREATEST" if session.get_bind().dialect.name == "postgresql" else "MAX"
    values = {"client": client, "now": now_s, "period": period_s, "tolerance": tolerance_s}
    if session.execute(text(_SPEND.format(high=high)), values).first() is not None:
        return None
    refused = session.scalar(select(t.AuthBucket.tat_s).where(t.AuthBucket.client == client))
    return float(refused) if refused is not None else None


def prune(*, session: Session, now_s: float) -> int:
    """Delete the buckets that are full again (their time has passed); how many."""
    done = session.execute(delete(t.AuthBucket).where(t.AuthBucket.tat_s < now_s))
    return int(getattr(done, "rowcount", 0) or 0)
