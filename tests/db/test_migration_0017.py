"""Migration 0017: a plan stored with a ``coverage_k`` below 0.5 (taken before) gets 0.5, the
least now taken, so that it can still be read; every other setting and plan is kept."""

from __future__ import annotations

import json

from sqlalchemy import text
from test_migration_0012 import _downgrade
from test_migration_0013 import _plans
from test_migrations import _no_difference

from db.engine import make_engine, upgrade
from db.plan_state import settings_of
from db.tables import utcnow
from supervisor.rcb.state import RcbSettings

#: Plans as 0016 stored them: name and settings JSON (or None).
OLD = (
    ("narrow", {"strategy": "learn", "alpha": 0.25, "coverage_k": 0.001, "z": 3.0}),
    ("half", {"strategy": "learn", "alpha": 0.25, "coverage_k": 0.5}),
    ("usual", {"strategy": "bayes", "alpha": 0.4, "coverage_k": 2.0}),
    ("defaults", {"strategy": "ivester", "alpha": 0.25}),
)


def store_plans(url: str, plans: tuple[tuple[str, dict], ...]) -> None:
    """A machine and ``plans`` (name, settings JSON) stored as 0016 to 0025 store them."""
    engine = make_engine(url)
    with engine.begin() as connection:
        connection.execute(
            text("INSERT INTO machines (name, limits, created_at) VALUES ('m', '{}', :now)"),
            {"now": utcnow()},
        )
        for name, settings in plans:
            connection.execute(
                text(
                    "INSERT INTO plans (name, machine_id, body, settings, current_setpoint_version,"
                    " state_token, fleet_changes_accepted, created_at) VALUES (:name,"
                    " (SELECT id FROM machines), '{}', :settings, 1, '', 0, :now)"
                ),
                {"name": name, "settings": json.dumps(settings), "now": utcnow()},
            )
    engine.dispose()


def test_0017_raises_a_coverage_k_below_a_half_and_keeps_the_rest(backend_url):
    upgrade(backend_url, "0016")
    store_plans(backend_url, OLD)
    upgrade(backend_url)
    stored = {name: row[0] for name, row in _plans(backend_url, "settings").items()}
    assert stored == {
        "narrow": {"strategy": "learn", "alpha": 0.25, "coverage_k": 0.5, "z": 3.0},
        **dict(OLD[1:]),
    }
    assert settings_of(stored["narrow"]) == RcbSettings("learn", coverage_k=0.5, z=3.0)
    _no_difference(backend_url)
    _downgrade(backend_url, "0016")
    assert {n: r[0] for n, r in _plans(backend_url, "settings").items()} == stored
