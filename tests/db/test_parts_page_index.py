"""A page of a plan's parts (``db/read/parts.py``) should be an index seek either way: the REST
``order=oldest`` (``id > cursor`` up) and ``order=newest`` (``id < cursor`` down).

SQLite's query plans. The query has the shape a seek needs (``plan_id = ?``, a range on ``id``,
ordered by ``id``, a LIMIT, no OFFSET) and ``ix_parts_plan_id`` ``(plan_id, id)`` (alembic
0028) serves it both ways; before it, ``ix_parts_plan_received`` ``(plan_id, received_at)``
was used and every part of the plan read and sorted for each page (``USE TEMP B-TREE FOR
ORDER BY``).
"""

from __future__ import annotations

import re
from typing import Any

import pytest
from sqlalchemy import Engine, event, text
from sqlalchemy.orm import Session

from db.read.parts import parts_page


@pytest.fixture
def engine(sqlite_engine: Engine) -> Engine:
    return sqlite_engine  # SQLite's: its query plans


def _plans(engine: Engine, *, newest: bool) -> list[str]:
    """The query-plan lines of the SELECT of ``parts`` a page runs (cursor 40, 10 a page)."""
    seen: list[tuple[str, Any]] = []

    def hear(conn: Any, cursor: Any, statement: str, parameters: Any, *args: Any) -> None:
        if "FROM parts" in statement:
            seen.append((statement, parameters))

    event.listen(engine, "before_cursor_execute", hear)
    try:
        with Session(engine) as session:
            parts_page(session=session, plan_id=1, after_id=40, limit=10, newest=newest)
    finally:
        event.remove(engine, "before_cursor_execute", hear)
    [(statement, parameters)] = seen
    with engine.connect() as connection:
        raw = connection.connection.driver_connection
        return [row[-1] for row in raw.execute("EXPLAIN QUERY PLAN " + statement, parameters)]


@pytest.mark.parametrize(("newest", "seek"), [(False, "id>?"), (True, "id<?")])
def test_with_an_index_on_plan_and_id_a_page_is_a_seek(engine, newest, seek):
    with engine.begin() as connection:
        connection.execute(text("CREATE INDEX IF NOT EXISTS ix_test ON parts (plan_id, id)"))
    plan = _plans(engine, newest=newest)
    [line] = plan
    assert re.fullmatch(rf"SEARCH parts USING INDEX \w+ \(plan_id=\? AND {re.escape(seek)}\)", line)


@pytest.mark.parametrize("newest", [False, True])
def test_the_schema_seeks_a_page_of_parts(engine, newest):
    plan = _plans(engine, newest=newest)
    assert not any("TEMP B-TREE" in line or line.startswith("SCAN") for line in plan), plan
