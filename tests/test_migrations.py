"""Migrations: `upgrade head` on an empty database, then autogenerate finds nothing to change."""

from __future__ import annotations

from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import inspect

from api.cli import app
from db.engine import make_engine, upgrade
from db.tables import Base


def _no_difference(url: str) -> None:
    engine = make_engine(url)
    try:
        with engine.connect() as connection:
            context = MigrationContext.configure(connection, opts={"compare_type": True})
            assert compare_metadata(context, Base.metadata) == []
            tables = set(inspect(connection).get_table_names())
        assert tables == {*Base.metadata.tables, "alembic_version"}
    finally:
        engine.dispose()


def test_sqlite_upgrade_head_then_no_difference(tmp_path):
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    upgrade(url)
    _no_difference(url)
    upgrade(url)  # a second upgrade is a no-op
    engine = make_engine(url)
    with engine.connect() as connection:  # WAL and foreign keys as db.engine promises
        assert connection.exec_driver_sql("PRAGMA journal_mode").scalar() == "wal"
        assert connection.exec_driver_sql("PRAGMA foreign_keys").scalar() == 1
    engine.dispose()


def test_postgres_upgrade_head_then_no_difference(empty_postgres):
    upgrade(empty_postgres)
    _no_difference(empty_postgres)


def test_rcb_db_upgrade_command(runner, tmp_path):
    url = f"sqlite:///{tmp_path / 'cli.db'}"
    result = runner.invoke(app, ["db", "upgrade", "--db", url])
    assert result.exit_code == 0, result.output
    assert "up to date" in result.stderr
    _no_difference(url)
    bad = runner.invoke(app, ["db", "upgrade", "--db", "nonsense://x"])
    assert bad.exit_code == 2 and "--db" in bad.stderr and "Traceback" not in bad.stderr
