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

from sqlalchemy import Engine, inspect, text
from sqlalchemy.engine import make_url

from db.engine import make_engine, upgrade

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
    if backend == "sqlite" and parsed.database and _empty(url):
        _copy_sqlite(Path(parsed.database))
    elif backend == "postgresql" and not parsed.query and _empty(url):
        _copy_postgres(url)
    else:
        upgrade(url)
        return
    _new_identity(url)


def copy_sqlite(source: Path, target: Path) -> None:
    """A consistent copy of a SQLite database (WAL included), whatever is connected to it."""
    with sqlite3.connect(source) as src, sqlite3.connect(target) as dst:
        src.backup(dst)
    src.close()
    dst.close()


def admin_engine(server: str) -> Engine:
    """An engine on the PostgreSQL server's database for ``CREATE`` and ``DROP DATABASE``."""
    return make_engine(server).execution_options(isolation_level="AUTOCOMMIT")


def _empty(url: str) -> bool:
    """Whether the database at ``url`` has no table, nor (PostgreSQL) settings of its own
    (``ALTER DATABASE ... SET``), which a copy made from the template would not keep."""
    parsed = make_url(url)
    if parsed.get_backend_name() == "sqlite":
        path = Path(parsed.database or "")
        if not path.exists() or path.stat().st_size == 0:
            return True
    engine = make_engine(url)
    try:
        with engine.connect() as connection:
            if inspect(connection).get_table_names():
                return False
            return (
                parsed.get_backend_name() != "postgresql"
                or not connection.execute(
                    text(
                        "SELECT count(*) FROM pg_db_role_setting s JOIN pg_database d"
                        " ON d.oid = s.setdatabase WHERE d.datname = current_database()"
                    )
                ).scalar()
            )
    finally:
        engine.dispose()


def _new_identity(url: str) -> None:
    """The copy's own identity, drawn anew; its one row proves the copy is a migrated one."""
    engine = make_engine(url)
    try:
        with engine.begin() as connection:
            renewed = connection.execute(
                text("UPDATE database_identity SET uuid = :uuid"), {"uuid": str(uuid.uuid4())}
            )
            assert renewed.rowcount == 1, f"the template did not reach {url}"
    finally:
        engine.dispose()


def _copy_sqlite(path: Path) -> None:
    """``path`` becomes a copy of this process's migrated SQLite template."""
    if "sqlite" not in _templates:
        folder = Path(tempfile.mkdtemp(prefix="rcb-template-"))
        atexit.register(shutil.rmtree, folder, ignore_errors=True)
        template = folder / "template.db"
        upgrade(f"sqlite:///{template}")
        _templates["sqlite"] = str(template)
    copy_sqlite(Path(_templates["sqlite"]), path)


def _copy_postgres(url: str) -> None:
    """The empty PostgreSQL database of ``url`` becomes a copy of this process's template."""
    from conftest import postgres_url  # the server the tests' databases are made on

    parsed = make_url(url)
    server = postgres_url() or url
    admin = admin_engine(server)
    try:
        with admin.connect() as connection:
            if "postgresql" not in _templates:
                template = f"rcb_test_template_{uuid.uuid4().hex[:12]}"
                connection.execute(text(f'CREATE DATABASE "{template}"'))
                _templates["postgresql"] = template
                atexit.register(_drop, server, template)
                upgrade(parsed.set(database=template).render_as_string(hide_password=False))
            template = _templates["postgresql"]
            connection.execute(text(f'DROP DATABASE "{parsed.database}"'))
            connection.execute(text(f'CREATE DATABASE "{parsed.database}" TEMPLATE "{template}"'))
    finally:
        admin.dispose()


def _drop(server: str, name: str) -> None:
    """Drop this process's PostgreSQL template (at exit)."""
    admin = admin_engine(server)
    try:
        with admin.connect() as connection:
            connection.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
    finally:
        admin.dispose()
