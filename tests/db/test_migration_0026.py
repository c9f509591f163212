"""Migration 0026: the plan of each audit entry already stored, from its target (``plan N``,
``plan N part S``; a creation's ``plan NAME`` by the plan of that name), none for the rest;
the index ``rcb audit --plan`` reads; the downgrade drops both."""

from __future__ import annotations

import json

from sqlalchemy import text
from test_migration_0012 import _downgrade
from test_migration_0017 import store_plans
from test_migrations import _no_difference

from db.engine import make_engine, upgrade
from db.tables import utcnow

#: Plans as 0025 stored them (ids 1 and 2, in this order).
PLANS = ("first-bar", "7")
#: Audit entries as 0025 stored them: action, target, and the plan 0026 must find.
ENTRIES = (
    ("create plan", "plan first-bar", 1),
    ("create plan", "plan 7", 2),  # a plan named "7" is plan 2, not plan 7
    ("create plan", "plan ghost", None),  # refused: no plan has that name
    ("report part", "plan 1 part SN-0001", 1),
    ("report part", "plan 2 part plan 1", 2),
    ("report part", "plan 99 part SN-1", None),  # no plan 99
    ("replan", "plan 2", 2),
    ("fleet exclude", "machine m", None),
    ("create key", "key 3", None),
    ("fleet change confirmed", "plan 1", 1),
    ("report part", "plan 1x part 2", None),
)


def _store(url: str) -> None:
    store_plans(url, tuple((name, {}) for name in PLANS))
    engine = make_engine(url)
    with engine.begin() as connection:
        for action, target, _ in ENTRIES:
            connection.execute(
                text(
                    "INSERT INTO audit_log (at, actor, action, target, result, detail)"
                    " VALUES (:at, 'cli', :action, :target, 'ok', :detail)"
                ),
                {"at": utcnow(), "action": action, "target": target, "detail": json.dumps({})},
            )
    engine.dispose()


def test_0026_finds_each_stored_entrys_plan(backend_url):
    upgrade(backend_url, "0025")
    _store(backend_url)
    upgrade(backend_url)
    engine = make_engine(backend_url)
    with engine.connect() as connection:
        found = connection.execute(
            text("SELECT action, target, plan_id FROM audit_log ORDER BY id")
        ).all()
    engine.dispose()
    assert [tuple(row) for row in found] == list(ENTRIES)
    _no_difference(backend_url)
    _downgrade(backend_url, "0025")
    engine = make_engine(backend_url)
    with engine.connect() as connection:
        columns = connection.execute(text("SELECT * FROM audit_log")).keys()
    engine.dispose()
    assert "plan_id" not in columns
