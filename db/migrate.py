"""Migrations under a lock: any number of instances may start at once on one database.

``rcb serve`` (and every ``rcb`` command on a database) migrates first. Two instances starting
together on one PostgreSQL both saw the database behind and both migrated: on a fresh database
one failed on the ``alembic_version`` row (UniqueViolation), on one at 0005 on a column the
other had just added (DuplicateColumn), and exited with a traceback (issue 29).

The upgrade now runs under a lock held for the whole of it, so the second instance waits, then
finds the database at head and has nothing to do (Alembic reads the revision only under the
lock):

- PostgreSQL: a transaction-level advisory lock, ``pg_advisory_xact_lock`` (PostgreSQL docs,
  "Advisory Locks"), with :data:`MIGRATION_LOCK` as its key, taken by the migrations' own
  transaction first (``alembic/env.py``: :func:`lock_in`; PostgreSQL migrates in one
  transaction) and released by its commit or rollback, or by the server when the connection
  ends, so a crashed instance never leaves it held. It holds through PgBouncer in transaction
  pooling too, where a session-level lock (this module's first form) would stay with whichever
  server connection took it and never be released by the unlock, sent over another.
- SQLite: an exclusive ``flock`` on ``<database>-migrate.lock`` beside the database file,
  dropped by the kernel when the process dies. The migration's own transaction starts with
  ``BEGIN IMMEDIATE`` (:mod:`db.engine`) too, but its wait is bounded by the busy timeout,
  which a long migration of a large database could exceed; the file lock waits without a bound.
"""

from __future__ import annotations

import fcntl
import os
from collections.abc import Iterator
from contextlib import contextmanager

from sqlalchemy import Connection, create_engine, text
from sqlalchemy.engine import URL, make_url
from sqlalchemy.pool import NullPool

from db.urls import without_pooler

#: The advisory lock's key on PostgreSQL (64 bits; "rcbmigr" in ASCII, so no other lock of
#: this service, whose keys are hashes of idempotency keys, is likely to share it).
MIGRATION_LOCK = 0x7263626D69677200


@contextmanager
def migration_lock(url: str) -> Iterator[None]:
    """Hold the database's migration lock for the duration of the block (waiting for it).

    PostgreSQL: a transaction of its own holds it (an upgrade takes it in its migrations'
    transaction instead, :func:`lock_in`); SQLite: the file lock.
    """
    parsed = make_url(url)
    if parsed.get_backend_name() == "postgresql":
        engine = create_engine(without_pooler(parsed), poolclass=NullPool)
        try:
            with engine.begin() as connection:
                lock_in(connection)
                yield
        finally:
            engine.dispose()
        return
    path = _lock_path(parsed) if parsed.get_backend_name() == "sqlite" else None
    try:
        fd = None if path is None else os.open(path, os.O_RDWR | os.O_CREAT, 0o600)
    except OSError:  # no such directory, read-only: SQLite says so, naming the database
        fd = None
    if fd is None:  # in memory (nobody else sees it), or a URL Alembic will refuse
        yield
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock


def lock_in(connection: Connection) -> None:
    """Take the PostgreSQL migration lock in ``connection``'s transaction (waiting for it)."""
    connection.execute(text("SELECT pg_advisory_xact_lock(:key)"), {"key": MIGRATION_LOCK})


def _lock_path(parsed: URL) -> str | None:
    """``<database>-migrate.lock`` beside a SQLite database file; None in memory."""
    database = parsed.database or ""
    if database in ("", ":memory:") or database.startswith("file:"):
        return None
    return os.path.abspath(database) + "-migrate.lock"
