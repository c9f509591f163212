"""Migration 0025: a plan stored with a ``z`` below 1 (taken before 2a8aedd) gets 1, the least
now taken, so that it can still be read; the raise is in the audit log; every other setting
and plan is kept."""

from __future__ import annotations

import json

import pytest
from sqlalchemy import text
from test_migration_0012 import _downgrade
from test_migration_0013 import _plans
from test_migration_0017 import store_plans
from test_migrations import _no_difference

from db.engine import make_engine, upgrade
from db.plan_state import settings_of
from models.errors import InputError
from supervisor.rcb.state import RcbSettings

#: Plans as 0024 stored them: name and settings JSON.
OLD = (
    ("narrow", {"strategy": "learn", "alpha": 0.25, "z": 0.5, "coverage_k": 3.0}),
    ("one", {"strategy": "learn", "alpha": 0.25, "z": 1}),
    ("usual", {"strategy": "learn", "alpha": 0.4, "z": 4.0}),
    ("defaults", {"strategy": "ivester", "alpha": 0.25}),
)


def _audit(url: str) -> list[tuple]:
    engine = make_engine(url)
    with engine.connect() as connection:
        rows = connection.execute(
            text("SELECT actor, action, target, result, detail FROM audit_log ORDER BY id")
        ).all()
    engine.dispose()
    return [(*row[:4], json.loads(row[4]) if isinstance(row[4], str) else row[4]) for row in rows]


def test_0025_raises_a_z_below_one_and_keeps_the_rest(backend_url):
    upgrade(backend_url, "0024")
    store_plans(backend_url, OLD)
    with pytest.raises(InputError, match="z = 0.5"):  # unreadable before: a plan locked out
        settings_of(OLD[0][1])
    upgrade(backend_url)
    stored = {name: row[0] for name, row in _plans(backend_url, "settings").items()}
    assert stored == {"narrow": {**OLD[0][1], "z": 1.0}, **dict(OLD[1:])}
    assert settings_of(stored["narrow"]) == RcbSettings("learn", coverage_k=3.0, z=1.0)
    narrow = 1  # the first plan stored
    assert _audit(backend_url) == [
        (
            "migration 0025",
            "raise z",
            f"plan {narrow}",
            "1.0",
            {"z_was": 0.5, "z": 1.0, "reason": "z under 1 is refused"},
        )
    ]
    _no_difference(backend_url)
    _downgrade(backend_url, "0024")
    assert {n: r[0] for n, r in _plans(backend_url, "settings").items()} == stored
