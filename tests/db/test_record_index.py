"""A plan's report finds its newest and its marked RCB decisions by index (alembic 0028).

A year's review measured the report's decision totals and newest decisions growing with the
plan's parts (8 000 parts: 8 and 13 ms, from 1.5 and 2.2 ms at 800): both read every decision
the plan made. SQLite's query plans now show seeks only: the newest decision of each
operation's quantity at the end of ``ix_rcb_decisions_operation_quantity_part``, the totals
from the partial, covering ``ix_rcb_decisions_marked`` (flagged or noted decisions alone).
The totals are checked against a count in Python over every decision, with marked ones in
two plans so that a plan's totals cannot take another's.
"""

from __future__ import annotations

import sqlite3
from collections import Counter

from sqlalchemy import event, select, update
from sqlalchemy.orm import Session
from test_service import BODY, _reports

from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan
from db import tables as t
from db.engine import make_engine
from db.read import record

from migrated import migrated


def _plans(url: str) -> list[int]:
    migrated(url)
    engine = make_engine(url)
    bodies, _ = _reports(4)
    ids = []
    for name in ("one", "two"):
        plan_id = create_plan(engine=engine, body={**BODY, "name": name}).body["id"]
        for body in bodies:
            report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
        ids.append(plan_id)
    with Session(engine) as session, session.begin():  # marks of each kind, in both plans
        d = t.RcbDecision
        rows = session.scalars(select(d.id).order_by(d.id)).all()
        marks = [
            {"flagged": True, "flag": "breach"},
            {"flagged": True, "flag": "above_band"},
            {"note": "implausible_low"},
            {"note": "regime_change"},
        ]
        for row, values in zip(rows[::5], marks * 10, strict=False):
            session.execute(update(d).where(d.id == row).values(**values))
    engine.dispose()
    return ids


def _counted(session: Session, plan_id: int) -> dict[str, int]:
    d = t.RcbDecision
    rows = session.scalars(
        select(d).join(t.Part, t.Part.id == d.part_id).where(t.Part.plan_id == plan_id)
    ).all()
    counts = Counter()
    for row in rows:
        counts["flagged"] += bool(row.flagged)
        counts["breaches"] += row.flag == "breach"
        counts["notes"] += row.note is not None
        counts["checks"] += row.note == "implausible_low"
    return {k: counts[k] for k in ("flagged", "breaches", "notes", "checks")}


def test_the_totals_and_newest_decisions_are_seeks_and_count_what_every_decision_shows(
    tmp_path,
) -> None:
    path = tmp_path / "record.db"
    url = f"sqlite:///{path}"
    ids = _plans(url)
    engine = make_engine(url)
    sent: list[tuple[str, tuple]] = []
    event.listen(engine, "before_cursor_execute", lambda c, cu, s, p, x, m: sent.append((s, p)))
    with Session(engine) as session:
        for plan_id in ids:
            totals = record.decision_totals(session=session, plan_id=plan_id)
            assert totals == _counted(session, plan_id), plan_id
            assert totals["flagged"] and totals["notes"], totals  # marks in both plans
            latest = record.last_decisions(session=session, plan_id=plan_id)
            newest = {(d.operation_id, d.quantity): d.part_id for d, _ in latest}
            d = t.RcbDecision
            every = session.execute(
                select(d.operation_id, d.quantity, d.part_id)
                .join(t.Part, t.Part.id == d.part_id)
                .where(t.Part.plan_id == plan_id)
            ).all()
            expected: dict[tuple[int, str], int] = {}
            for op, quantity, part in every:
                expected[(op, quantity)] = max(part, expected.get((op, quantity), 0))
            assert newest == expected and len(latest) == len(expected) == 12
    engine.dispose()
    plans = []
    with sqlite3.connect(path) as raw:
        for statement, parameters in sent:
            if "rcb_decisions" in statement and statement.lstrip().startswith("SELECT"):
                plans += [r[-1] for r in raw.execute("EXPLAIN QUERY PLAN " + statement, parameters)]
    decisions = [p for p in plans if "rcb_decisions" in p]
    assert decisions and not [p for p in decisions if p.startswith("SCAN")], plans
    assert any("COVERING INDEX ix_rcb_decisions_marked" in p for p in decisions), plans
    by_operation_alone = [
        p for p in decisions if "ix_rcb_decisions_operation_quantity_part (operation_id=?)" in p
    ]
    assert not by_operation_alone, plans  # every decision of an operation: what grew
