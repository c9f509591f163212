"""``alembic/env.py`` checks SQLite's references (``PRAGMA foreign_key_check``) after a migration
ran, and only then: at head every command (``rcb keys list``, ``rcb serve``) migrates first, and
the check, which reads every row with a reference, grew from 15 to 124 ms over a year of history.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator
from typing import Any

import pytest
from sqlalchemy import Engine, event

from db.engine import current_revision, revisions, upgrade

CHECK = "PRAGMA foreign_key_check"


@pytest.fixture
def statements() -> Iterator[list[str]]:
    """Every SQL statement any engine runs while the test does (the migrations make their own)."""
    seen: list[str] = []

    def hear(conn: Any, cursor: Any, statement: str, *args: Any) -> None:
        seen.append(statement)

    event.listen(Engine, "before_cursor_execute", hear)
    yield seen
    event.remove(Engine, "before_cursor_execute", hear)


def _dangling_part(path: str) -> None:
    """A part of a plan that does not exist, written with foreign keys off."""
    with sqlite3.connect(path) as raw:
        raw.execute("PRAGMA foreign_keys=OFF")
        raw.execute(
            "INSERT INTO parts (plan_id, serial, setpoint_version, received_at) "
            "VALUES (999, 'ORPHAN', 1, '2026-01-01 00:00:00')"
        )


def test_the_check_runs_after_a_migration_and_not_at_head(tmp_path, statements):
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    before_last, head = revisions()[-2], revisions()[-1]
    upgrade(url, before_last)
    assert statements.count(CHECK) == 1  # from empty: every migration, one check at the end
    statements.clear()
    upgrade(url)  # one migration: checked
    assert current_revision(url) == head
    assert statements.count(CHECK) == 1
    statements.clear()
    upgrade(url)  # at head: nothing to migrate, nothing to check
    assert any("alembic_version" in s for s in statements), statements  # it did look
    assert statements.count(CHECK) == 0


def test_a_migration_that_leaves_a_broken_reference_is_still_refused(tmp_path):
    path = tmp_path / "rcb.db"
    url = f"sqlite:///{path}"
    upgrade(url, revisions()[-2])
    _dangling_part(str(path))
    with pytest.raises(SystemExit, match="the migrations broke references"):
        upgrade(url)


def test_at_head_a_reference_is_not_read_again(tmp_path):
    """The check guards what a migration rebuilt; at head no table was rebuilt (a row written
    with foreign keys off is the writer's doing, not the migrations')."""
    path = tmp_path / "rcb.db"
    url = f"sqlite:///{path}"
    upgrade(url)
    _dangling_part(str(path))
    assert upgrade(url).after == revisions()[-1]
