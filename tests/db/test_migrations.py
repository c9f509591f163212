"""Migrations: `upgrade head` on an empty database, then autogenerate finds nothing to change;
0004 -> 0005 keeps an older plan, which reads back running with the default settings."""

from __future__ import annotations

import json

from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import inspect, text

from api.cli.main import app
from db.engine import HEAD_REVISION, make_engine, revisions, upgrade
from db.plan_state import settings_of
from db.tables import Base, utcnow
from supervisor.rcb.state import RcbSettings


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


def test_the_head_a_command_checks_without_alembic_is_alembics():
    """db.engine.HEAD_REVISION: a new migration is written there too, or this fails."""
    assert revisions()[-1] == HEAD_REVISION


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
    head = revisions()[-1]
    assert result.stderr == f"rcb: database {url} migrated from empty to revision {head}\n"
    _no_difference(url)
    again = runner.invoke(app, ["db", "upgrade", "--db", url])
    assert again.stderr == f"rcb: database {url} is up to date (revision {head})\n"
    bad = runner.invoke(app, ["db", "upgrade", "--db", "nonsense://x"])
    assert bad.exit_code == 2 and "--db" in bad.stderr and "Traceback" not in bad.stderr


def _columns(url: str, table: str) -> dict[str, bool]:
    engine = make_engine(url)
    try:
        with engine.connect() as connection:
            return {c["name"]: c["nullable"] for c in inspect(connection).get_columns(table)}
    finally:
        engine.dispose()


def _upgrade_0004_to_0005(url: str) -> None:
    """0005 adds nullable columns: a plan stored at 0004 reads back running, with defaults."""
    upgrade(url, "0004")
    assert "settings" not in _columns(url, "plans")
    engine = make_engine(url)
    with engine.begin() as connection:
        connection.execute(
            text("INSERT INTO machines (name, created_at) VALUES ('m', :now)"), {"now": utcnow()}
        )
        connection.execute(
            text(
                "INSERT INTO plans (name, machine_id, body, strategy, alpha,"
                " current_setpoint_version, state_token, created_at)"
                " VALUES ('old', (SELECT id FROM machines), '{}', 'ivester', 0.25, 1, '', :now)"
            ),
            {"now": utcnow()},
        )
    engine.dispose()
    upgrade(url)
    new = {
        "rcb_decisions": ("flag", "note"),
        "plans": ("settings", "halt"),
        "band_states": ("posterior",),
    }
    for table, names in new.items():
        columns = _columns(url, table)
        assert all(columns[name] for name in names), (table, columns)  # present, nullable
    engine = make_engine(url)
    with engine.connect() as connection:
        row = connection.execute(text("SELECT settings, halt FROM plans")).one()
    engine.dispose()
    # 0013 moved strategy and alpha into settings: every other setting the default
    assert (json.loads(row.settings) if isinstance(row.settings, str) else row.settings) == {
        "strategy": "ivester",
        "alpha": 0.25,
    }
    assert row.halt is None
    assert settings_of({"strategy": "ivester", "alpha": 0.25}) == RcbSettings("ivester")
    _no_difference(url)


def test_sqlite_0005_adds_flags_settings_halt_and_posterior(tmp_path):
    _upgrade_0004_to_0005(f"sqlite:///{tmp_path / 'old.db'}")


def test_postgres_0005_adds_flags_settings_halt_and_posterior(empty_postgres):
    _upgrade_0004_to_0005(empty_postgres)
