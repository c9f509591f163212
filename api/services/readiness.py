"""Readiness: whether the database would take a part report now (``GET /ready``).

``/health`` says the process answers; a load balancer or the MES also needs to know whether a
report would be stored (a lockout review: with the SQLite file locked by another process,
``/health`` said ok while every report waited 30 s for a 503). The probe opens a write
transaction and rolls it back, waiting at most :data:`READY_WAIT_MS` for the lock: on SQLite
``BEGIN IMMEDIATE`` takes the write lock (:mod:`db.engine`), on PostgreSQL the server answers
a statement. The probe also issues a write that changes no row (an ``UPDATE`` of the version
table ``WHERE`` false): a database rcb cannot write (a SQLite file or directory read-only, a
PostgreSQL standby or ``default_transaction_read_only``) fails it, and ``/ready`` is 503
naming the database as not writable (:mod:`api.rest.unavailable`), where before it said ready
and every report was a 500. It writes nothing.
"""

from __future__ import annotations

from sqlalchemy import Engine, text

from db.engine import waiting_at_most
from db.urls import VERSION_TABLE

#: Longest the probe waits for the database's write lock [ms].
READY_WAIT_MS = 1000


def ready(engine: Engine) -> dict[str, str]:
    """``{"status": "ready"}``, or the database's error (a 503 over REST, with its reason)."""
    with waiting_at_most(engine, READY_WAIT_MS) as connection:
        connection.execute(
            text(f"UPDATE {VERSION_TABLE} SET version_num = version_num WHERE 1 = 0")
        )
        connection.rollback()
    return {"status": "ready"}
