"""Which database errors mean "not now" (503 with ``Retry-After``) rather than a bug (500).

A request that finds no free connection in its worker's pool within the pool's timeout
(``sqlalchemy.exc.TimeoutError``, :class:`db.engine.Pool`), a PostgreSQL server out of
connections ("sorry, too many clients already", SQLSTATE 53300) or not reachable, and a SQLite
database still locked after its busy timeout are answered 503 ``database_busy`` with
``Retry-After``: nothing was stored, and the same request may be sent again (with its
Idempotency-Key). Before, they were 500 "nothing was stored", which a client cannot tell from a
bug (issue 29). So is a database that takes no writes (a SQLite file or its directory made
read-only, a PostgreSQL standby or read-only transaction, SQLSTATE 25006): the reason names it
as not writable, for the operator to fix; ``GET /ready`` says so before any report fails.
"""

from __future__ import annotations

from sqlalchemy.exc import DBAPIError
from sqlalchemy.exc import TimeoutError as PoolTimeoutError

from db.urls import read_only

#: The ``Retry-After`` of a 503 [s].
RETRY_AFTER_S = 1
#: SQLSTATE classes and codes of a server that cannot serve now (PostgreSQL Appendix A):
#: 08 connection exception, 53 insufficient resources (53300 too many connections), 55P03 a
#: lock not available within ``lock_timeout`` (:data:`db.engine.PG_LOCK_TIMEOUT_MS`), 57P01-3
#: shutting down, crashed, cannot connect now.
_SQLSTATE_BUSY = ("08", "53", "55P03", "57P01", "57P02", "57P03")
#: What SQLite says when its busy timeout ran out.
_SQLITE_BUSY = ("database is locked", "database is busy")
#: What libpq says when a connection cannot be opened (no SQLSTATE is reported then).
_CONNECT_FAILED = ("too many clients", "connection failed", "connection refused")


def unavailable(err: BaseException) -> bool:
    """Whether ``err`` says the database cannot serve this request now (retry later)."""
    if isinstance(err, PoolTimeoutError):
        return True
    if not isinstance(err, DBAPIError):
        return False
    if err.connection_invalidated or read_only(err):
        return True
    sqlstate = getattr(err.orig, "sqlstate", None)
    if isinstance(sqlstate, str) and sqlstate:
        return sqlstate.startswith(_SQLSTATE_BUSY)
    message = str(err.orig).lower()
    return any(text in message for text in _SQLITE_BUSY + _CONNECT_FAILED)


def reason(err: BaseException) -> str:
    """What a 503's detail says of ``err`` (one :func:`unavailable` accepts), in a few words."""
    if isinstance(err, PoolTimeoutError):
        return "the database has no connection free now"
    sqlstate = getattr(getattr(err, "orig", None), "sqlstate", None) or ""
    message = str(getattr(err, "orig", err)).lower()
    if read_only(err):
        return "the database is not writable (read-only)"
    if sqlstate == "55P03":
        return "a row it needs is locked by another transaction"
    if any(text in message for text in _SQLITE_BUSY):
        return "the database is locked by another writer"
    if sqlstate.startswith("53") or "too many clients" in message:
        return "the database server has no connection free now"
    return "the database cannot be reached now"
