"""A page of parts ``since`` a time (``rcb parts --since``, ``GET .../parts?since=``) costs the
same after a year of parts as after a day (``db/read/parts.py``, ``first_since``).

The cost is SQLite's virtual-machine instructions, counted by a progress handler called at
each one: repeatable, unlike seconds. Before, the page's own query filtered ``received_at``
and its seek started at the plan's first part: the first page ``order=oldest`` of 11 parts
since took 20 305 instructions after 4000 parts and 505 after 40; now 484 and 484.
"""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

import pytest
from sqlalchemy import Engine, insert
from sqlalchemy.orm import Session
from test_service import BODY

from api.services.plans import create_plan
from db import tables as t
from db.read.parts import parts_page

T0 = datetime(2026, 1, 1, tzinfo=UTC)


@pytest.fixture
def engine(sqlite_engine: Engine) -> Engine:
    return sqlite_engine  # SQLite's: its progress handler counts the instructions


def _stored(engine: Engine, count: int, name: str) -> int:
    """A plan with ``count`` parts, one a minute from T0 (no measurements: a page's cost)."""
    plan_id = create_plan(engine=engine, body={**BODY, "name": name}).body["id"]
    rows = [
        {"plan_id": plan_id, "serial": f"{name}-{i}", "setpoint_version": 1,
         "received_at": T0 + timedelta(minutes=i)}
        for i in range(count)
    ]  # fmt: skip
    with engine.begin() as connection:
        connection.execute(insert(t.core_table(t.Part)), rows)
    return plan_id


def _page(engine: Engine, plan_id: int, since: datetime, **kw) -> tuple[list[str], bool, int]:
    """The serials of a page of 10, whether more follow, and the VM instructions it took."""
    steps = 0

    def count() -> int:
        nonlocal steps
        steps += 1
        return 0

    with engine.connect() as connection:
        raw = connection.connection.driver_connection
        raw.set_progress_handler(count, 1)
        try:
            with Session(bind=connection) as session:
                parts, _, _, more = parts_page(
                    session=session, plan_id=plan_id, limit=10, since=since, **kw
                )
        finally:
            raw.set_progress_handler(None, 1)
    return [p.serial for p in parts], more, steps


@pytest.mark.parametrize(
    ("kw", "since", "shown", "more"),
    [
        ({"after_id": 0}, 11, range(11, 1, -1), True),  # 11 parts since: a page and one more
        ({"after_id": 0, "newest": True}, 11, range(10, 0, -1), True),
        ({"after_id": 0, "newest": True}, 9, range(9, 0, -1), False),  # the last page
    ],
    ids=["oldest", "newest", "newest-last-page"],
)
def test_a_page_since_costs_the_same_after_100_times_the_parts(engine, kw, since, shown, more):
    """``since`` and ``shown`` count back from the plan's newest part (1: the newest)."""
    costs = []
    for count in (40, 4000):
        plan_id = _stored(engine, count, f"p{count}")
        serials, more_seen, steps = _page(
            engine, plan_id, T0 + timedelta(minutes=count - since), **kw
        )
        assert serials == [f"p{count}-{count - back}" for back in shown]
        assert more_seen is more
        costs.append(steps)
    assert costs[1] < 1.5 * costs[0], costs


def test_nothing_since_is_an_empty_last_page(engine):
    plan_id = _stored(engine, 3, "p")
    for newest in (False, True):
        page = _page(engine, plan_id, T0 + timedelta(days=9999), after_id=0, newest=newest)
        assert page[:2] == ([], False)


def test_a_part_stored_first_but_stamped_later_is_not_lost(engine):
    """Two reports racing for the plan's lock: the first stored was stamped second."""
    plan_id = _stored(engine, 3, "p")
    late = {"plan_id": plan_id, "setpoint_version": 1}
    hour = T0 + timedelta(hours=1)
    with engine.begin() as connection:
        connection.execute(
            insert(t.core_table(t.Part)),
            [
                {
                    **late,
                    "serial": "stored-first",
                    "received_at": T0 + timedelta(hours=1, seconds=1),
                },
                {**late, "serial": "stored-second", "received_at": hour},
            ],
        )
    serials, more, _ = _page(engine, plan_id, hour, after_id=0)
    assert serials == ["stored-first", "stored-second"] and more is False
