"""``rcb db prune`` deletes the band states a newer one replaced, and nothing a reader needs
(:mod:`db.state_retention`), on SQLite and PostgreSQL.

Before, ``band_states`` kept a row per band per part for ever: 29 kB a part on the
demonstration plan, 80 % of what the database grew by, and only each band's newest row (and,
while a process change waits to be judged, the newest before it) is ever read.
"""

from __future__ import annotations

import json
from datetime import timedelta

from hypothesis import given, settings
from hypothesis import strategies as st
from sqlalchemy import delete as sql_delete
from sqlalchemy import select, update
from sqlalchemy.orm import Session
from test_service import BODY, _reports

from api.cli.main import app
from api.rest.schemas.parts import parse_report
from api.services import retention
from api.services.parts import report_part
from api.services.plans import create_plan
from db import tables as t
from db.fleet_changes import _before as before_change
from db.state_retention import prunable_states

from conftest import engine_url, stored_state

#: Parts the MES reported, and how many of the first are made older than the retention.
PARTS, OLD = 8, 6


def _rows(engine) -> list[tuple[int, int, str, int]]:
    """Every band state as (id, operation id, quantity, part id)."""
    b = t.BandState
    with Session(engine) as session:
        query = select(b.id, b.operation_id, b.quantity, b.part_id).order_by(b.id)
        return [tuple(row) for row in session.execute(query)]


def _age(engine, serials: list[str], days: float) -> set[int]:
    """Make the parts ``serials`` ``days`` older; their ids."""
    with Session(engine) as session, session.begin():
        session.execute(
            update(t.Part)
            .where(t.Part.serial.in_(serials))
            .values(received_at=t.Part.received_at - timedelta(days=days))
        )
        return set(session.scalars(select(t.Part.id).where(t.Part.serial.in_(serials))))


def _replaced(rows, old_parts: set[int], cut: int | None = None) -> set[int]:
    """The ids the rule deletes, worked out here row by row: of an old part, and a newer row of
    its band that is also before ``cut`` where the row is."""
    gone = set()
    for row_id, op, quantity, part in rows:
        newer = [p for _, o, q, p in rows if (o, q) == (op, quantity) and p > part]
        if cut is not None and part < cut:
            newer = [p for p in newer if p < cut]
        if part in old_parts and newer:
            gone.add(row_id)
    return gone


def _same_state(a, b) -> None:
    """Two loads of one plan hold the same learner state (what the next report starts from)."""
    assert a.version == b.version and a.tools == b.tools
    assert a.sigma == b.sigma and a.seen == b.seen
    assert a.posterior == b.posterior and a.wear == b.wear and a.monitors == b.monitors
    for x, y in zip(a.setpoints.operations, b.setpoints.operations, strict=True):
        assert (x.setpoint, x.binding) == (y.setpoint, y.binding)


def _prior(engine, name: str) -> object:
    """The fleet prior a new plan named ``name`` stored."""
    plan_id = create_plan(engine=engine, body={**BODY, "name": name}, prior="fleet").body["id"]
    with Session(engine) as session:
        return session.get(t.Plan, plan_id).prior


def test_prune_deletes_old_replaced_states_and_the_plan_learns_on_as_before(engine, monkeypatch):
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    bodies, replayed = _reports(PARTS + 2)
    for body in bodies[:PARTS]:
        report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
    old = _age(engine, [b["serial"] for b in bodies[:OLD]], days=40)
    rows = _rows(engine)
    gone = _replaced(rows, old)
    assert len(gone) >= OLD * 6  # most bands moved at most old parts
    loaded, prior = stored_state(engine, plan_id), _prior(engine, "before-prune")
    assert prior  # a fleet prior: the plan's learned beliefs

    monkeypatch.setattr(retention, "STATES_BATCH", 7)  # several transactions
    pruned = retention.prune(engine=engine)  # 30d: the 40-day-old parts' replaced states

    assert pruned["band_states"] == len(gone)
    assert {row[0] for row in _rows(engine)} == {row[0] for row in rows} - gone
    _same_state(stored_state(engine, plan_id), loaded)
    assert _prior(engine, "after-prune") == prior  # the fleet reads the same evidence
    for body in bodies[PARTS:]:  # the plan goes on as the replay that kept every state
        report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
    _same_state(stored_state(engine, plan_id), replayed)
    assert retention.prune(engine=engine)["band_states"] == 0  # nothing more is old


def test_the_state_before_a_pending_change_is_kept(engine):
    """While a change of the plan's process waits to be judged, the fleet compares what the
    plan learned before the part it opened at with what it learned since (db.fleet_changes)."""
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    bodies, _ = _reports(PARTS)
    for body in bodies:
        report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
    parts = _age(engine, [b["serial"] for b in bodies], days=2)
    with Session(engine) as session, session.begin():
        cut = session.scalar(select(t.Part.id).where(t.Part.serial == bodies[4]["serial"]))
        session.execute(update(t.Plan).where(t.Plan.id == plan_id).values(fleet_change_part=cut))
    rows = _rows(engine)
    gone = _replaced(rows, parts, cut)
    with Session(engine) as session:
        judged = before_change(session, plan_id)
    assert sum(belief is not None for belief in judged.values()) >= 6  # a belief per operation

    pruned = retention.prune(engine=engine, states_older_than="1d")

    assert pruned["band_states"] == len(gone) > 0
    kept = _rows(engine)
    assert {row[0] for row in kept} == {row[0] for row in rows} - gone
    assert max(sum((o, q) == (op, qty) for _, o, q, _ in kept) for _, op, qty, _ in kept) == 2
    with Session(engine) as session:
        assert before_change(session, plan_id) == judged


def test_rcb_db_prune_says_how_many_states_and_refuses_a_bad_age(runner, engine):
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    bodies, _ = _reports(3)
    for body in bodies:
        report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
    _age(engine, [b["serial"] for b in bodies], days=31)
    rows, url = _rows(engine), engine_url(engine)

    refused = runner.invoke(app, ["db", "prune", "--states-older-than", "a month", "--db", url])
    assert refused.exit_code == 2 and "Traceback" not in refused.stderr
    assert "--states-older-than = 'a month'" in refused.stderr
    assert _rows(engine) == rows  # nothing deleted, audit entries neither

    done = runner.invoke(app, ["db", "prune", "--json", "--db", url])
    assert done.exit_code == 0, done.output
    answer = json.loads(done.stdout)
    assert answer["band_states"] == len(rows) - len(_rows(engine)) > 0
    assert {"states_before", "audit_before", "idempotency_before"} <= set(answer)
    with Session(engine) as session:
        entry = session.scalars(
            select(t.AuditEntry).where(t.AuditEntry.action == "prune").order_by(t.AuditEntry.id)
        ).all()[-1]
    assert entry.detail["band_states"] == answer["band_states"]
    assert entry.target == "older than 365d / 7d / 30d"


#: A random history (Hypothesis): per part, the bands (of 3) its report moved.
_moved = st.lists(st.sets(st.integers(0, 2), min_size=1), min_size=1, max_size=10)


def _stored_history(engine, plan_id: int, bands, moved, old: int) -> dict[int, tuple]:
    """Parts 1..len(moved) of ``plan_id`` (the first ``old`` 40 days old), a band state for
    each band a part moved; {state id: (band, part number, part id)}."""
    now = t.utcnow()
    states = {}
    with Session(engine) as session, session.begin():
        session.execute(sql_delete(t.BandState))
        session.execute(sql_delete(t.Part))
        for number, touched in enumerate(moved, start=1):
            part = t.Part(
                plan_id=plan_id,
                serial=f"p{number}",
                setpoint_version=1,
                received_at=now - timedelta(days=40 if number <= old else 0),
            )
            session.add(part)
            session.flush()
            for band in sorted(touched):
                op, quantity = bands[band]
                row = t.BandState(
                    operation_id=op, quantity=quantity, part_id=part.id, seen=1.0, sigma=0.1
                )
                session.add(row)
                session.flush()
                states[row.id] = (band, number, part.id)
    return states


def test_the_prune_keeps_what_is_read_and_deletes_the_rest_of_what_is_old(sqlite_engine):
    """Any history (Hypothesis): the rows kept are each band's newest, the newest before a
    pending change, and the states of recent parts; every other row is deleted."""
    plan_id = create_plan(engine=sqlite_engine, body=BODY).body["id"]
    with Session(sqlite_engine) as session:
        ops = session.scalars(select(t.Operation.id).where(t.Operation.plan_id == plan_id))
        first, second = list(ops)[:2]
    bands = [(first, "force_N"), (first, "roughness_um"), (second, "force_N")]

    @settings(max_examples=60, deadline=None)
    @given(moved=_moved, old=st.integers(0, 10), cut=st.none() | st.integers(1, 10))
    def check(moved, old, cut) -> None:
        states = _stored_history(sqlite_engine, plan_id, bands, moved, old)
        part_ids = {number: part for _, number, part in states.values()}
        cut_part = None if cut is None else part_ids.get(cut)  # None past the last part
        with Session(sqlite_engine) as session, session.begin():
            session.execute(
                update(t.Plan).where(t.Plan.id == plan_id).values(fleet_change_part=cut_part)
            )
        read = set()  # what a reader reads: each band's newest, and its newest before the cut
        for band in range(3):
            rows = sorted((n, i) for i, (b, n, _) in states.items() if b == band)
            if rows:
                read.add(rows[-1][1])
            before = [i for n, i in rows if cut_part is not None and n < cut]
            if before:
                read.add(before[-1])
        recent = {i for i, (_, n, _) in states.items() if n > old}
        with Session(sqlite_engine) as session:
            gone = set(prunable_states(session=session, before=t.utcnow() - timedelta(days=30),
                                       limit=1000))  # fmt: skip
        assert gone == set(states) - read - recent

    check()
