"""A change of a plan's process keeps it out of the fleet where its readings since confirm it
(issue 32; db/fleet_changes.py, supervisor/fleet/changes.py, alembic 0022-0023), through real part
reports, on SQLite and PostgreSQL.

Before, every change its monitors counted took the plan out until an engineer put it back; the
monitors' false alarms (one in about 2 600 readings a quantity) then took 57 of 90 plans out
after 300 parts on a steady fleet (benchmarks/closed_loop.py --fleet 4 --learn-parts 300).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session
from test_fleet_db import FLEET, LEARN, _body
from test_migration_0012 import _downgrade
from test_migrations import _no_difference

from api.rest.schemas.parts import parse_report
from api.services.fleet_models import include_in_fleet
from api.services.parts import report_part
from api.services.plans import create_plan, replan
from db import tables as t
from db.fleet import fleet_evidence
from db.fleet_members import members
from supervisor.fleet.changes import CONFIRM_Z
from supervisor.virtual.fleet import noise_seed
from supervisor.virtual.simulate import run_part

from conftest import engine_url, stored_state
from migrated import migrated


def _parts(engine, plan_id: int, serials: range, scale: float = 1.0) -> None:  # type: ignore[no-untyped-def]
    """Parts of ``plan_id`` on machine 0 of the fleet, rough-od's force read ``scale`` x."""
    rng = np.random.default_rng([*noise_seed(11, 0), serials.start])
    for i in serials:
        state = stored_state(engine, plan_id)
        outcome = run_part(
            FLEET[0], {op.name: op.setpoint for op in state.setpoints.operations}, rng
        )
        operations: list[dict[str, Any]] = []
        for op, measured in outcome.measurements.items():
            values = {
                q: {"value": m.value, "uncertainty": m.uncertainty} for q, m in measured.items()
            }
            if op == "rough-od":
                values["force_N"]["value"] *= scale
            operations.append({"name": op, "measurements": values})
        body = {"serial": f"a-{i}", "setpoint_version": state.version, "operations": operations}
        assert report_part(engine=engine, plan_id=plan_id, report=parse_report(body)).status == 201


def _rough_od_readings(engine) -> int | None:  # type: ignore[no-untyped-def]
    """The readings of plan a's rough-od force the fleet reads (None: the plan is out)."""
    with Session(engine) as session:
        found = fleet_evidence(session=session, tool_names=["CNMG432RN"])
    if not found:
        return None
    (item,) = [
        i for i in found if i.operation.name == "rough-od" and i.posterior.quantity == "force_N"
    ]
    return item.posterior.observations


def _cut(engine, plan_id: int) -> str | None:  # type: ignore[no-untyped-def]
    with Session(engine) as session:
        row = session.get(t.Plan, plan_id)
        assert row is not None
        part = row.fleet_change_part
        return (
            None if part is None else session.scalar(select(t.Part.serial).where(t.Part.id == part))
        )


def _member(engine):  # type: ignore[no-untyped-def]
    with Session(engine) as session:
        (member,) = members(session=session, tool="CNMG432RN", after_id=0, limit=10)
    return member


def _counted(engine, plan_id: int) -> int:  # type: ignore[no-untyped-def]
    return sum(m.changes for m in stored_state(engine, plan_id).monitors.values())


def _entry(engine, action: str) -> t.AuditEntry:  # type: ignore[no-untyped-def]
    with Session(engine) as session:
        return session.scalars(select(t.AuditEntry).where(t.AuditEntry.action == action)).one()


def _plan(engine) -> int:  # type: ignore[no-untyped-def]
    return int(
        create_plan(engine=engine, body=_body("fleet-a", "lathe-0"), settings=LEARN).body["id"]
    )


def test_a_change_the_readings_confirm_keeps_the_plan_out_until_an_engineer_accepts(
    engine,
) -> None:
    a = _plan(engine)
    _parts(engine, a, range(1, 7))
    assert _cut(engine, a) is None and _rough_od_readings(engine) == 6
    _parts(engine, a, range(7, 13), scale=1.15)  # rough-od's force 15 % up for good
    assert _cut(engine, a) == "a-7" and _counted(engine, a) >= 1
    assert _rough_od_readings(engine) is None  # judged at a-12: confirmed, out
    assert _member(engine).out == (
        "its process changed at part a-7, confirmed by its readings "
        f"({_counted(engine, a)} not accepted: rcb fleet include --plan {a} --changes "
        f"{_counted(engine, a)})"
    )
    entry = _entry(engine, "fleet change confirmed")
    assert (entry.actor, entry.target) == ("rcb", f"plan {a}")
    assert entry.result == "out of the fleet until rcb fleet include"
    assert entry.detail is not None and entry.detail["largest_shift"] == "rough-od force_N"
    assert entry.detail["part"] == "a-7"  # the serial the surfaces say (an audit: the id alone)
    assert entry.detail["z"] > CONFIRM_Z
    _parts(engine, a, range(13, 15), scale=1.15)  # judged once: no second verdict
    assert _entry(engine, "fleet change confirmed").id == entry.id
    include_in_fleet(engine=engine, plan_id=a, machine=None)
    assert _cut(engine, a) is None
    assert _rough_od_readings(engine) == 14  # accepted: everything it learned
    with Session(engine) as session:
        actions = list(session.scalars(select(t.AuditEntry.action)))
    assert "fleet change not confirmed" not in actions


def test_a_change_the_readings_do_not_confirm_is_accepted_five_parts_on(engine) -> None:
    """One reading 15 % high, then the process as before: the monitor counts a change, the
    plan is out, and five parts on its readings show the law where it was (a false alarm, as
    the CUSUM's on a steady process): the change is accepted by itself and said so in the
    audit log, and the plan is back with everything it learned."""
    a = _plan(engine)
    _parts(engine, a, range(1, 7))
    _parts(engine, a, range(7, 8), scale=1.15)
    assert _cut(engine, a) == "a-7" and _counted(engine, a) == 1
    _parts(engine, a, range(8, 12))
    assert _rough_od_readings(engine) is None  # four parts on: not judged yet
    assert _member(engine).out == (
        "its process changed at part a-7, to be judged once 5 parts have followed it "
        f"(1 not accepted: rcb fleet include --plan {a} --changes 1)"
    )
    _parts(engine, a, range(12, 13))
    assert _cut(engine, a) is None and _rough_od_readings(engine) == 12
    with Session(engine) as session:
        row = session.get(t.Plan, a)
        assert row is not None and row.fleet_changes_accepted == 1
    entry = _entry(engine, "fleet change not confirmed")
    assert (entry.actor, entry.target, entry.result) == ("rcb", f"plan {a}", "accepted")
    assert entry.detail is not None and 0 <= entry.detail["z"] <= CONFIRM_Z
    assert _member(engine).out == ""


def test_a_reset_of_the_bands_forgets_the_change(engine) -> None:
    a = _plan(engine)
    _parts(engine, a, range(1, 4))
    _parts(engine, a, range(4, 6), scale=1.15)
    assert _cut(engine, a) == "a-4"
    assert replan(engine=engine, plan_id=a, changes={"reset_bands": True}).status == 201
    assert _cut(engine, a) is None
    _parts(engine, a, range(6, 8), scale=1.15)
    assert _rough_od_readings(engine) == 2  # learned since the reset, its process as it is now


def _confirmed_flags(engine) -> dict[str, bool]:  # type: ignore[no-untyped-def]
    with Session(engine) as session:
        rows = session.execute(select(t.Plan.name, t.Plan.fleet_change_confirmed)).all()
    return {name: bool(flag) for name, flag in rows}


def test_0023_marks_the_changes_0022_had_judged_confirmed(engine) -> None:
    """Under 0022 a change not confirmed was cleared at its sixth part: one still marked after
    more parts was confirmed, one with fewer is still to be judged. Down to 0022 and up again,
    the upgrade tells them apart from the parts alone."""
    a = _plan(engine)
    _parts(engine, a, range(1, 7))
    _parts(engine, a, range(7, 15), scale=1.15)  # change at a-7, confirmed at a-12
    b = int(create_plan(engine=engine, body=_body("b", "lathe-1"), settings=LEARN).body["id"])
    _parts(engine, b, range(1, 7))
    _parts(engine, b, range(7, 10), scale=1.15)  # change at b-7, judged at b-12: not yet
    assert _cut(engine, b) is not None
    assert _confirmed_flags(engine) == {"fleet-a": True, "b": False}
    url = engine_url(engine)
    engine.dispose()
    _downgrade(url, "0022")
    migrated(url)
    assert _confirmed_flags(engine) == {"fleet-a": True, "b": False}
    _no_difference(url)
