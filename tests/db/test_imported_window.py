"""Each imported machine's newest plans, read by a walk that stops (alembic 0031).

``db.fleet_window.newest_imported`` steps through a tool's imported machines one seek each
and walks each machine's rows from the newest; before, it grouped every imported row of the
tool by plan for every new plan (``benchmarks/imported_window.py``: the window 57 times as
slow at 100 000 rows as at 1 000). These tests hold the walk to the definition, worked in
Python on the same rows: per tool, origin and machine, the ``n`` plans whose last imported
row is newest.
"""

from __future__ import annotations

import random
from collections import defaultdict

from hypothesis import given, settings
from hypothesis import strategies as st
from sqlalchemy import Engine, delete, insert, select
from sqlalchemy.orm import Session

from db import tables as t
from db.fleet_window import newest_imported

TOOLS = ("CNMG432RN", "VCMR331", "OTHER")
ORIGINS = ("", "0c5f0b7e-0000-4000-8000-000000000001", "6f1c2a3b-0000-4000-8000-000000000002")

Row = tuple[str, str, str, str]  # tool, origin, machine, plan


def _expected(rows: list[Row], tools: list[str], n: int) -> set[Row]:
    """The definition: a plan is as new as its last row (the highest id, the list's order)."""
    last: dict[Row, int] = {}
    for i, row in enumerate(rows):
        last[row] = i
    by_machine: dict[tuple[str, str, str], list[tuple[int, str]]] = defaultdict(list)
    for (tool, origin, machine, plan), i in last.items():
        if tool in tools:
            by_machine[(tool, origin, machine)].append((i, plan))
    return {
        (*key, plan)
        for key, plans in by_machine.items()
        for _, plan in sorted(plans, reverse=True)[:n]
    }


def _stored(engine: Engine, rows: list[Row]) -> None:
    """``rows`` as imported models, in order (ids rising), each its own operation."""
    with Session(engine) as session, session.begin():
        session.execute(delete(t.ImportedModel))
        values = [
            {
                "tool": tool,
                "origin": origin,
                "machine": machine,
                "plan": plan,
                "operation": f"op-{i}",
                "quantity": "force_N",
                "body": {},
                "source": "test",
            }
            for i, (tool, origin, machine, plan) in enumerate(rows)
        ]
        if values:
            session.execute(insert(t.core_table(t.ImportedModel)), values)


def _window(engine: Engine, tools: list[str], n: int) -> set[Row]:
    with Session(engine) as session:
        dialect = session.get_bind().dialect.name
        found = session.execute(select(newest_imported(tools, dialect, n))).all()
    return {tuple(row) for row in found}  # type: ignore[misc]


_rows = st.lists(  # few machines, many plans revisited: which are newest is decided late
    st.tuples(
        st.sampled_from(TOOLS[:2]),
        st.sampled_from(ORIGINS[:2]),
        st.sampled_from(("lathe-0", "")),
        st.sampled_from([f"plan-{k}" for k in range(6)]),
    ),
    max_size=40,
)


def test_the_walk_picks_each_machines_newest_plans(sqlite_engine) -> None:
    """Any rows (Hypothesis): ties of plans across machines and origins, the empty origin
    of a version 1 document and an empty machine's name, no rows of a tool at all."""

    @settings(max_examples=60, deadline=None)
    @given(rows=_rows, tools=st.lists(st.sampled_from(TOOLS), min_size=1, max_size=3))
    def check(rows: list[Row], tools: list[str]) -> None:
        _stored(sqlite_engine, rows)
        assert _window(sqlite_engine, tools, 2) == _expected(rows, tools, 2)

    check()


def test_the_walk_holds_on_both_databases_with_many_rows(engine) -> None:
    """300 rows of 2 tools, 2 origins, 2 machines, 24 plans each imported again now and then
    (PostgreSQL's walk is a LATERAL join, SQLite's an IN): the 10 newest plans of each."""
    pick = random.Random(7)
    rows = [
        (
            pick.choice(TOOLS[:2]),
            pick.choice(ORIGINS[:2]),
            pick.choice(("lathe-0", "")),
            f"plan-{pick.randrange(24)}",  # each plan imported again now and then
        )
        for i in range(300)
    ]
    _stored(engine, rows)
    for tools in (["CNMG432RN"], ["CNMG432RN", "VCMR331"], list(TOOLS), ["NONE"]):
        assert _window(engine, tools, 10) == _expected(rows, tools, 10), tools
