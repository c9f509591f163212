"""Every time the service reads back is UTC, whatever zone the database's sessions use.

PostgreSQL returns ``timestamptz`` in the session's zone (a plant's server may be set to
local time); SQLite returns it naive. Both are read as UTC by one function,
:func:`db.table_base.as_utc`, so a plan's, a setpoint version's and an audit entry's times
carry offset 0 on every surface.
"""

from __future__ import annotations

import json
from datetime import UTC, datetime, timedelta, timezone

from sqlalchemy import text

from api.cli.main import app
from db.engine import make_engine, upgrade
from db.table_base import as_utc

from conftest import ROOT
from migrated import admin_engine

PLAN = ROOT / "examples" / "ivester_demo_part.toml"


def test_as_utc_reads_naive_as_utc_and_converts_aware():
    naive = datetime(2026, 12, 1, 9, 30)
    assert as_utc(naive) == datetime(2026, 12, 1, 9, 30, tzinfo=UTC)
    tokyo = datetime(2026, 12, 1, 18, 30, tzinfo=timezone(timedelta(hours=9)))
    converted = as_utc(tokyo)
    assert converted.utcoffset() == timedelta(0)
    assert converted == datetime(2026, 12, 1, 9, 30, tzinfo=UTC)


def _json(runner, *args: str) -> dict:
    done = runner.invoke(app, [*args, "--json"])
    assert done.exit_code == 0, done.stderr
    return json.loads(done.stdout)


def test_times_are_utc_from_a_database_in_another_zone(runner, empty_postgres):
    name = empty_postgres.rsplit("/", 1)[1]
    admin = admin_engine(empty_postgres)
    with admin.connect() as connection:
        connection.execute(text(f"ALTER DATABASE \"{name}\" SET timezone TO 'Asia/Tokyo'"))
        assert connection.execute(text("SELECT 1")).scalar() == 1
    admin.dispose()
    upgrade(empty_postgres)
    created = runner.invoke(app, ["plans", "create", str(PLAN), "--db", empty_postgres])
    assert created.exit_code == 0, created.stderr
    with make_engine(empty_postgres).connect() as connection:  # the zone took
        assert connection.execute(text("SHOW timezone")).scalar() == "Asia/Tokyo"
    times = [
        _json(runner, "plans", "--db", empty_postgres)["plans"][0]["created_at"],
        _json(runner, "history", "1", "--db", empty_postgres)["versions"][0]["created_at"],
        _json(runner, "audit", "--db", empty_postgres)["entries"][0]["at"],
    ]
    for moment in times:
        assert moment.endswith("+00:00"), times
        assert abs(datetime.fromisoformat(moment) - datetime.now(UTC)) < timedelta(minutes=5)
