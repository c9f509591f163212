"""Migration 0012: a machine's four limit columns become one JSON column keyed by quantity,
each stored value carried over (NULL: the key absent), and back on a downgrade."""

from __future__ import annotations

import json

from alembic.config import Config
from sqlalchemy import text
from test_migrations import _columns, _no_difference

from alembic import command
from db.engine import MIGRATIONS, make_engine, upgrade
from db.tables import utcnow

#: Machines as 0011 stored them: the four columns (None: NULL, no limit).
OLD = {
    "lathe": {"max_power_kW": 22.0, "max_spindle_rpm": 4000.0, "max_torque_Nm": 250.0,
              "max_feed_rate_mm_min": 5000.0},
    "mill": {"max_power_kW": 5.5, "max_spindle_rpm": None, "max_torque_Nm": None,
             "max_feed_rate_mm_min": 500.0},
    "bare": {"max_power_kW": None, "max_spindle_rpm": None, "max_torque_Nm": None,
             "max_feed_rate_mm_min": None},
}  # fmt: skip
NEW = {
    "lathe": {"power_kW": 22.0, "spindle_rpm": 4000.0, "torque_Nm": 250.0,
              "feed_rate_mm_min": 5000.0},
    "mill": {"power_kW": 5.5, "feed_rate_mm_min": 500.0},
    "bare": {},
}  # fmt: skip
COLUMNS = tuple(OLD["lathe"])


def _downgrade(url: str, revision: str) -> None:
    config = Config()
    config.set_main_option("script_location", str(MIGRATIONS))
    config.attributes["url"] = url
    command.downgrade(config, revision)


def _quoted(columns: tuple[str, ...]) -> str:
    return ", ".join(f'"{c}"' for c in columns)


def _limits(url: str) -> dict[str, dict]:
    found = _rows(url, "limits").items()
    return {name: json.loads(v) if isinstance(v, str) else v for name, (v,) in found}


def _rows(url: str, columns: str) -> dict[str, tuple]:
    engine = make_engine(url)
    try:
        with engine.connect() as connection:
            found = connection.execute(text(f"SELECT name, {columns} FROM machines")).all()
    finally:
        engine.dispose()
    return {row[0]: tuple(row[1:]) for row in found}


def test_0012_carries_the_limits_over_and_back(backend_url):
    upgrade(backend_url, "0011")
    engine = make_engine(backend_url)
    with engine.begin() as connection:
        for name, limits in OLD.items():
            connection.execute(
                text(
                    "INSERT INTO machines (name, created_at, " + _quoted(COLUMNS) + ")"
                    " VALUES (:name, :now, " + ", ".join(f":{c}" for c in COLUMNS) + ")"
                ),
                {"name": name, "now": utcnow(), **limits},
            )
    engine.dispose()
    upgrade(backend_url)
    assert not set(COLUMNS) & set(_columns(backend_url, "machines"))
    assert _limits(backend_url) == NEW
    _no_difference(backend_url)
    _downgrade(backend_url, "0011")
    assert "limits" not in _columns(backend_url, "machines")
    back = _rows(backend_url, _quoted(COLUMNS))
    assert back == {name: tuple(limits.values()) for name, limits in OLD.items()}
    upgrade(backend_url)  # and up again
    assert _limits(backend_url) == NEW
