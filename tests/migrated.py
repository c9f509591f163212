"""A database at the head revision in milliseconds: a copy of one migrated once per worker.

Alembic's migrations take 0.1-0.3 s per database and the suite's fixtures migrate several
hundred whose tests are not about migrating (py-spy over a full run, 2026-12-05: 75 s of
CPU). :func:`migrated` copies a template migrated once per process instead: SQLite by its
backup API, PostgreSQL by ``CREATE DATABASE ... TEMPLATE``. The one row a migration writes
that belongs to one database, its identity (alembic 0020, the key of models imported once),
is drawn anew in each copy. Tests of the migrations themselves call
:func:`db.engine.upgrade`.
"""

from __future__ import annotations

import atexit
import shutil
import sqlite3
import tempfile
import uuid
from pathlib import Path

from sqlalchemy import create_engine, inspect, text
from sqlalchemy.engine import URL, make_url
from sqlalchemy.pool import NullPool

from db.engine import current_revision, upgrade

#: Each backend's template in this process: a SQLite path, a PostgreSQL database name.
_templates: dict[str, str] = {}


def migrated(url: str) -> None:
    """Bring the new, empty database at ``url`` to head, as ``upgrade(url)`` does.

    A database that holds a table already, a PostgreSQL database with settings of its own, and
    one reached through a pooler (a URL with options: PgBouncer holds its connections) are
    migrated by :func:`db.engine.upgrade`.
    """
    parsed = make_url(url)
    backend = parsed.get_backend_name()
    if backend == "sqlite" and parsed.database and not _has_tables(url):
        _copy_sqlite(Path(parsed.database))
    elif (
        backend == "postgresql"
        and not parsed.query
        and not _has_tables(url)
        and not _has_settings(url)
    ):
        _copy_postgres(url)
    else:
        upgrade(url)
        return
    assert current_revision(url) is not None, f"the template did not reach {url}"


def _has_tables(url: str) -> bool:
    """Whether the database at ``url`` exists with a table in it."""
    parsed = make_url(url)
    if parsed.get_backend_name() == "sqlite":
        path = Path(parsed.database or "")
        if not path.exists() or path.stat().st_size == 0:
            return False
    engine = create_engine(url, poolclass=NullPool)
    try:
        with engine.connect() as connection:
            return bool(inspect(connection).get_table_names())
    finally:
        engine.dispose()


def _has_settings(url: str) -> bool:
    """Whether the PostgreSQL database at ``url`` has settings of its own (``ALTER DATABASE
    ... SET``), which a copy made from the template would not keep."""
    engine = create_engine(url, poolclass=NullPool)
    try:
        with engine.connect() as connection:
            return bool(
                connection.execute(
                    text(
                        "SELECT count(*) FROM pg_db_role_setting s JOIN pg_database d"
                        " ON d.oid = s.setdatabase WHERE d.datname = current_database()"
                    )
                ).scalar()
            )
    finally:
        engine.dispose()


def _new_identity(connection: sqlite3.Connection) -> None:
    connection.execute("UPDATE database_identity SET uuid = ?", (str(uuid.uuid4()),))
    connection.commit()


def _copy_sqlite(path: Path) -> None:
    """``path`` becomes a copy of this process's migrated SQLite template."""
    if "sqlite" not in _templates:
        folder = Path(tempfile.mkdtemp(prefix="rcb-template-"))
        atexit.register(shutil.rmtree, folder, ignore_errors=True)
        template = folder / "template.db"
        upgrade(f"sqlite:///{template}")
        _templates["sqlite"] = str(template)
    source = sqlite3.connect(_templates["sqlite"])
    target = sqlite3.connect(path)
    try:
        source.backup(target)
        _new_identity(target)
    finally:
        target.close()
        source.close()


def _copy_postgres(url: str) -> None:
    """The empty PostgreSQL database of ``url`` becomes a copy of this process's template."""
    from conftest import postgres_url  # the server the tests' databases are made on

    parsed, server = make_url(url), make_url(postgres_url() or url)
    name = parsed.database
    admin = create_engine(server, poolclass=NullPool, isolation_level="AUTOCOMMIT")
    try:
        with admin.connect() as connection:
            if "postgresql" not in _templates:
                template = f"rcb_test_template_{uuid.uuid4().hex[:12]}"
                connection.execute(text(f'CREATE DATABASE "{template}"'))
                _templates["postgresql"] = template
                atexit.register(_drop, server, template)
                upgrade(parsed.set(database=template).render_as_string(hide_password=False))
            template = _templates["postgresql"]
            connection.execute(text(f'DROP DATABASE "{name}"'))
            connection.execute(text(f'CREATE DATABASE "{name}" TEMPLATE "{template}"'))
    finally:
        admin.dispose()
    engine = create_engine(url, poolclass=NullPool)
    try:
        with engine.begin() as connection:
            connection.execute(
                text("UPDATE database_identity SET uuid = :uuid"), {"uuid": str(uuid.uuid4())}
            )
    finally:
        engine.dispose()


def _drop(server: URL, name: str) -> None:
    """Drop this process's PostgreSQL template (at exit)."""
    admin = create_engine(server, poolclass=NullPool, isolation_level="AUTOCOMMIT")
    try:
        with admin.connect() as connection:
            connection.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
    finally:
        admin.dispose()
