"""Engines: SQLite (embedded default) and PostgreSQL (psycopg 3), and migrations.

SQLite runs in WAL mode with a busy timeout, foreign keys on, and every transaction opened
with ``BEGIN IMMEDIATE``: a writer takes the write lock when it starts instead of upgrading a
read lock later, which is what raises "database is locked" under concurrent writers
(SQLite docs, "Write-Ahead Logging" and "BEGIN TRANSACTION"; SQLAlchemy docs, pysqlite
"Serializable isolation / Savepoints / Transactional DDL").
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from sqlalchemy import Engine, create_engine, event
from sqlalchemy.engine import make_url

from db.bulk import hook_engine

#: The embedded default database, in the directory rcb runs in.
DEFAULT_URL = "sqlite:///./rcb.db"
#: Milliseconds a SQLite writer waits for the lock before giving up.
SQLITE_BUSY_TIMEOUT_MS = 30_000
_READ_ONLY = "rcb_read_only"
#: The Alembic scripts (top-level ``alembic/`` of the repository).
MIGRATIONS = Path(__file__).resolve().parent.parent / "alembic"


def make_engine(url: str) -> Engine:
    """An engine for ``url`` with the settings above for SQLite.

    Its sessions may defer rows to the end of their transaction (:func:`db.bulk.defer`).
    """
    parsed = make_url(url)
    if parsed.get_backend_name() != "sqlite":
        # a pool as large as a worker's concurrency, so connections are reused rather than
        # opened and closed under load (4 workers x 24 stays under PostgreSQL's default 100)
        engine = create_engine(url, pool_pre_ping=True, pool_size=16, max_overflow=8)
        hook_engine(engine)
        return engine
    engine = create_engine(url, connect_args={"timeout": SQLITE_BUSY_TIMEOUT_MS / 1000})
    hook_engine(engine)

    @event.listens_for(engine, "connect")
    def _connect(dbapi_connection: Any, _record: Any) -> None:
        dbapi_connection.isolation_level = None  # SQLAlchemy emits BEGIN itself (below)
        cursor = dbapi_connection.cursor()
        if parsed.database not in (None, "", ":memory:"):
            cursor.execute("PRAGMA journal_mode=WAL")
        cursor.execute(f"PRAGMA busy_timeout={SQLITE_BUSY_TIMEOUT_MS}")
        cursor.execute("PRAGMA foreign_keys=ON")
        cursor.close()

    @event.listens_for(engine, "begin")
    def _begin(connection: Any) -> None:
        read_only = connection.get_execution_options().get(_READ_ONLY, False)
        connection.exec_driver_sql("BEGIN" if read_only else "BEGIN IMMEDIATE")

    return engine


def reader(engine: Engine) -> Engine:
    """The same engine for read-only use.

    On SQLite its transactions open with a deferred ``BEGIN``, so readers do not queue for the
    write lock (WAL gives each reader a consistent snapshot).
    """
    return engine.execution_options(**{_READ_ONLY: True})


def one_statement_reader(engine: Engine) -> Engine:
    """The same engine for a read that is one statement (an API key's lookup).

    On PostgreSQL it runs without ``BEGIN``/``COMMIT`` (autocommit: one statement is its own
    transaction and sees what was committed before it, as in a READ COMMITTED transaction),
    two round trips fewer; on SQLite it is :func:`reader`.
    """
    if engine.dialect.name == "postgresql":
        return engine.execution_options(isolation_level="AUTOCOMMIT")
    return reader(engine)


def upgrade(url: str, revision: str = "head") -> None:
    """Apply the Alembic migrations to ``url`` up to ``revision``."""
    from alembic.config import Config

    from alembic import command

    config = Config()
    config.set_main_option("script_location", str(MIGRATIONS))
    config.attributes["url"] = url
    command.upgrade(config, revision)
