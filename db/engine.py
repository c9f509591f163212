"""Engines: SQLite (embedded default) and PostgreSQL (psycopg 3), and migrations.

SQLite runs in WAL mode with a busy timeout, foreign keys on, and every writing transaction
opened with ``BEGIN IMMEDIATE``: a writer takes the write lock when it starts instead of
upgrading a read lock later, which is what raises "database is locked" under concurrent
writers (SQLite docs, "Write-Ahead Logging" and "BEGIN TRANSACTION"; SQLAlchemy docs, pysqlite
"Serializable isolation / Savepoints / Transactional DDL").

Reads do not starve writes (issue 17: four viewers reading history cut one MES client's
reports a hundredfold). :func:`reader` is a second engine on the same database with its own,
small pool (:data:`READ_POOL_SIZE` connections, no overflow): the history, parts and model
reads of a worker share it, so they cannot take the connections the reports need and at most
that many of them compute at once in a worker; a further read waits for a connection (up to
:data:`READ_POOL_TIMEOUT_S`), holding no connection, no lock and no CPU. On SQLite its
transactions open with a deferred ``BEGIN``: WAL gives each reader a snapshot outside the
write lock. A key's lookup on every request stays on the writers' pool
(:func:`one_statement_reader`), so a report never queues behind a viewer.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sqlalchemy import Connection, Engine, create_engine, event
from sqlalchemy.engine import URL, make_url

from db.bulk import hook_engine
from db.urls import POOLER_PARAM, behind_pooler

#: The embedded default database, in the directory rcb runs in.
DEFAULT_URL = "sqlite:///./rcb.db"
#: Milliseconds a SQLite writer waits for the lock before giving up.
SQLITE_BUSY_TIMEOUT_MS = 30_000
#: Milliseconds a PostgreSQL statement waits for a lock (a plan's row) before it fails: a
#: report of a plan whose row another client holds (a stuck transaction, a psql session) is a
#: 503 then, instead of waiting without end and holding a pooled connection, until the
#: pool ran dry and other plans' reports were refused too (a lockout review). A report holds
#: its plan's row for tens of milliseconds, a replan for about a second.
PG_LOCK_TIMEOUT_MS = 10_000
#: Connections of a worker's read pool (:func:`reader`): reads computing at once per worker.
READ_POOL_SIZE = 1
#: Seconds a read waits for a connection of the read pool before it fails.
READ_POOL_TIMEOUT_S = 120
_READ_ONLY = "rcb_read_only"
#: The Alembic scripts (top-level ``alembic/`` of the repository).
MIGRATIONS = Path(__file__).resolve().parent.parent / "alembic"
_readers: weakref.WeakKeyDictionary[Engine, Engine] = weakref.WeakKeyDictionary()
_readers_lock = threading.Lock()


@dataclass(frozen=True)
class Pool:
    """The writers' connection pool of one process (``rcb serve``: of each worker).

    Parameters
    ----------
    size : int
        Connections kept open.
    overflow : int
        Connections opened beyond ``size`` under load, closed when given back.
    timeout_s : float
        How long a request waits for a connection when all are in use [s]; then
        ``sqlalchemy.exc.TimeoutError`` (503 over REST: :mod:`api.rest.problems`).

    The defaults give 10 + 5 + 1 (the read pool, :func:`reader`) = 16 connections per worker
    at most: 4 workers (2 instances x 2, or 1 x 4) hold at most 64 of PostgreSQL's default
    ``max_connections`` 100 (of which 3 are reserved for superusers), leaving room for the
    CLI, migrations and other clients. ``rcb serve`` reads them from ``RCB_DB_POOL_SIZE``,
    ``RCB_DB_MAX_OVERFLOW`` and ``RCB_DB_POOL_TIMEOUT`` (:mod:`api.settings`).
    """

    size: int = 10
    overflow: int = 5
    timeout_s: float = 5.0

    def connections(self) -> int:
        """The most connections one process opens: writers' pool and overflow, and reads."""
        return self.size + self.overflow + READ_POOL_SIZE


#: The pool of a process not told otherwise.
DEFAULT_POOL = Pool()


def make_engine(url: str, pool: Pool = DEFAULT_POOL) -> Engine:
    """An engine for ``url`` with the settings above for SQLite, its pool sized by ``pool``.

    Its sessions may defer rows to the end of their transaction (:func:`db.bulk.defer`).
    """
    return _engine(
        make_url(url), pool_size=pool.size, max_overflow=pool.overflow, pool_timeout=pool.timeout_s
    )


def _engine(parsed: URL, *, read_pool: bool = False, **pool: Any) -> Engine:
    if parsed.get_backend_name() != "sqlite":
        engine = create_engine(parsed, pool_pre_ping=True, **pool)
        if behind_pooler(parsed):  # the URL keeps the parameter: the read engine sees it too
            event.listen(engine, "do_connect", _through_pooler)
        elif parsed.get_backend_name() == "postgresql":
            event.listen(engine, "do_connect", _lock_timeout)
        hook_engine(engine)
        return engine
    engine = create_engine(parsed, connect_args={"timeout": SQLITE_BUSY_TIMEOUT_MS / 1000}, **pool)
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
        read_only = read_pool or connection.get_execution_options().get(_READ_ONLY, False)
        connection.exec_driver_sql("BEGIN" if read_only else "BEGIN IMMEDIATE")

    return engine


def _lock_timeout(_dialect: Any, _record: Any, _args: Any, params: dict[str, Any]) -> None:
    """Connect with ``lock_timeout`` :data:`PG_LOCK_TIMEOUT_MS` (libpq's ``options``).

    Options the URL gives are kept, and a ``lock_timeout`` among them wins. Not through
    PgBouncer, which refuses the startup parameter: there, set it on the database role
    (``docs/guide/rest-service.md``).
    """
    given = str(params.get("options") or "")
    if "lock_timeout" not in given:
        params["options"] = f"{given} -c lock_timeout={PG_LOCK_TIMEOUT_MS}".strip()


def _through_pooler(_dialect: Any, _record: Any, _args: Any, params: dict[str, Any]) -> None:
    """The driver arguments through PgBouncer (:data:`db.urls.POOLER_PARAM`).

    The URL's parameter is not libpq's, and no statement is prepared on the server.
    """
    params.pop(POOLER_PARAM, None)
    params["prepare_threshold"] = None


def reader(engine: Engine) -> Engine:
    """The read engine of ``engine`` (made by :func:`make_engine`): its own bounded pool.

    On SQLite its transactions open with a deferred ``BEGIN``, so readers do not queue for the
    write lock (WAL gives each reader a consistent snapshot). It is made on first use and
    disposed with ``engine``.
    """
    if engine.dialect.name == "sqlite" and engine.url.database in (None, "", ":memory:"):
        return engine.execution_options(**{_READ_ONLY: True})  # one database per connection
    with _readers_lock:
        found = _readers.get(engine)
        if found is None:
            found = _readers[engine] = _engine(
                engine.url,
                read_pool=True,
                pool_size=READ_POOL_SIZE,
                max_overflow=0,
                pool_timeout=READ_POOL_TIMEOUT_S,
            )
            event.listen(engine, "engine_disposed", lambda _engine: found.dispose())
        return found


@contextmanager
def waiting_at_most(engine: Engine, wait_ms: int) -> Iterator[Connection]:
    """A connection of ``engine`` whose writes wait at most ``wait_ms`` for SQLite's write lock.

    For a write that is worth less than the time it would wait (a key's last use): the busy
    timeout of that connection only, restored when it goes back to the pool. PostgreSQL's
    connections are given as they are (:data:`PG_LOCK_TIMEOUT_MS` bounds their waits).
    """
    with engine.connect() as connection:
        if engine.dialect.name != "sqlite":
            yield connection
            return
        raw = connection.connection.dbapi_connection
        assert raw is not None
        raw.execute(f"PRAGMA busy_timeout={int(wait_ms)}")  # outside any transaction
        try:
            yield connection
        finally:
            raw.execute(f"PRAGMA busy_timeout={SQLITE_BUSY_TIMEOUT_MS}")


def one_statement_reader(engine: Engine) -> Engine:
    """The same engine for a read that is one statement (an API key's lookup).

    On PostgreSQL it runs without ``BEGIN``/``COMMIT`` (autocommit: one statement is its own
    transaction and sees what was committed before it, as in a READ COMMITTED transaction),
    two round trips fewer; on SQLite its transaction opens with a deferred ``BEGIN``. Either
    way on the writers' pool: every request checks a key, and must not wait for the readers.
    """
    if engine.dialect.name == "postgresql":
        return engine.execution_options(isolation_level="AUTOCOMMIT")
    return engine.execution_options(**{_READ_ONLY: True})


@dataclass(frozen=True)
class Migration:
    """What :func:`upgrade` did: the revision the database was at, and the one it is at now.

    Parameters
    ----------
    before : str or None
        The revision found under the lock; None for a database never migrated (empty).
    after : str or None
        The revision after the upgrade.
    """

    before: str | None
    after: str | None

    def changed(self) -> bool:
        """Whether the upgrade applied any migration."""
        return self.before != self.after


#: The newest migration's revision, so that a command checks a database against it without
#: loading Alembic (about 0.12 s of a command's 1 s); tests/db/test_migrations.py checks it
#: is Alembic's head, so a new migration fails the suite until it is written here.
HEAD_REVISION = "0031"


def revisions() -> tuple[str, ...]:
    """The revisions of the migrations (:data:`MIGRATIONS`), oldest first; the last is head."""
    from alembic.config import Config
    from alembic.script import ScriptDirectory

    config = Config()
    config.set_main_option("script_location", str(MIGRATIONS))
    found = ScriptDirectory.from_config(config).walk_revisions()  # newest first
    return tuple(reversed([script.revision for script in found]))


def upgrade(url: str, revision: str = "head") -> Migration:
    """Apply the Alembic migrations to ``url`` up to ``revision``, under the migration lock.

    Instances starting at once on one database migrate one after another; the later ones find
    it at ``revision`` (:func:`db.migrate.migration_lock`). Returns the revisions before and
    after, both read under the lock.
    """
    from alembic.config import Config

    from alembic import command
    from db.migrate import migration_lock

    config = Config()
    config.set_main_option("script_location", str(MIGRATIONS))
    config.attributes["url"] = url
    if make_url(url).get_backend_name() == "postgresql":
        # the lock is taken, and the revision read, in the migrations' transaction (env.py)
        command.upgrade(config, revision)
        return Migration(before=config.attributes.get("before"), after=current_revision(url))
    with migration_lock(url):
        before = current_revision(url)
        command.upgrade(config, revision)
        return Migration(before=before, after=current_revision(url))


def current_revision(url: str) -> str | None:
    """The Alembic revision of the database at ``url``; None when it was never migrated."""
    from sqlalchemy.pool import NullPool

    from db.urls import revision, without_pooler

    engine = create_engine(without_pooler(make_url(url)), poolclass=NullPool)
    try:
        with engine.connect() as connection:
            return revision(connection)
    finally:
        engine.dispose()
