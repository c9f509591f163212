"""Readiness: whether the database would take a part report now (``GET /ready``).

``/health`` says the process answers; a load balancer or the MES also needs to know whether a
report would be stored (a lockout review: with the SQLite file locked by another process,
``/health`` said ok while every report waited 30 s for a 503). The probe opens a write
transaction and rolls it back, waiting at most :data:`READY_WAIT_MS` for the lock: on SQLite
``BEGIN IMMEDIATE`` takes the write lock (:mod:`db.engine`), on PostgreSQL the server answers
a statement. It writes nothing.
"""

from __future__ import annotations

from sqlalchemy import Engine, text

from db.engine import waiting_at_most

#: Longest the probe waits for the database's write lock [ms].
READY_WAIT_MS = 1000


def ready(engine: Engine) -> dict[str, str]:
    """``{"status": "ready"}``, or the database's error (a 503 over REST, with its reason)."""
    with waiting_at_most(engine, READY_WAIT_MS) as connection:
        connection.execute(text("SELECT 1"))
        connection.rollback()
    return {"status": "ready"}
