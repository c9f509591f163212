"""Migration 0013: a plan's strategy and alpha columns move into its ``settings`` JSON (a NULL
settings becomes a table of those two), and back on a downgrade."""

from __future__ import annotations

import json

from sqlalchemy import text
from test_migration_0012 import _downgrade
from test_migrations import _columns, _no_difference

from db.engine import make_engine, upgrade
from db.plan_state import settings_of
from db.tables import utcnow
from supervisor.rcb.state import RcbSettings

#: Plans as 0012 stored them: (name, strategy, alpha, settings JSON or None).
OLD = (
    ("old", "ivester", 0.25, None),  # stored before 0005: every other setting the default
    ("tuned", "bayes", 0.4, {"z": 5.0, "halt_over": 0.5}),
)


def _plans(url: str, columns: str) -> dict[str, tuple]:
    engine = make_engine(url)
    try:
        with engine.connect() as connection:
            rows = connection.execute(text(f"SELECT name, {columns} FROM plans ORDER BY id"))
            found = {row[0]: tuple(row[1:]) for row in rows}
    finally:
        engine.dispose()
    return {
        name: tuple(json.loads(v) if isinstance(v, str) and v[:1] == "{" else v for v in row)
        for name, row in found.items()
    }


def test_0013_carries_strategy_and_alpha_over_and_back(backend_url):
    upgrade(backend_url, "0012")
    engine = make_engine(backend_url)
    with engine.begin() as connection:
        connection.execute(
            text("INSERT INTO machines (name, limits, created_at) VALUES ('m', '{}', :now)"),
            {"now": utcnow()},
        )
        for name, strategy, alpha, settings in OLD:
            connection.execute(
                text(
                    "INSERT INTO plans (name, machine_id, body, strategy, alpha, settings,"
                    " current_setpoint_version, state_token, created_at) VALUES (:name,"
                    " (SELECT id FROM machines), '{}', :strategy, :alpha, :settings, 1, '', :now)"
                ),
                {
                    "name": name,
                    "strategy": strategy,
                    "alpha": alpha,
                    "settings": None if settings is None else json.dumps(settings),
                    "now": utcnow(),
                },
            )
    engine.dispose()
    upgrade(backend_url)
    assert not {"strategy", "alpha"} & set(_columns(backend_url, "plans"))
    stored = {name: row[0] for name, row in _plans(backend_url, "settings").items()}
    assert stored == {
        "old": {"strategy": "ivester", "alpha": 0.25},
        "tuned": {"strategy": "bayes", "alpha": 0.4, "z": 5.0, "halt_over": 0.5},
    }
    assert settings_of(stored["old"]) == RcbSettings("ivester")
    assert settings_of(stored["tuned"]) == RcbSettings("bayes", 0.4, z=5.0, halt_over=0.5)
    _no_difference(backend_url)
    _downgrade(backend_url, "0012")
    back = _plans(backend_url, "strategy, alpha, settings")
    assert back == {
        "old": ("ivester", 0.25, {}),
        "tuned": ("bayes", 0.4, {"z": 5.0, "halt_over": 0.5}),
    }
    upgrade(backend_url)
    _no_difference(backend_url)
