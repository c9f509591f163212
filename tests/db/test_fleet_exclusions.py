"""Which plans make the fleet (issue 32): an engineer takes a plan or a machine out and puts it
back; a plan whose process changed is out by itself until then (SQLite and PostgreSQL).

The changes here are written into the monitors' stored state, with no part at which they were
counted, so none is judged; a change counted by a part report is judged five parts on, and
accepted by itself where the readings show a false alarm (tests/db/test_fleet_changes.py)."""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import Session
from test_fleet_db import LEARN, _body, _learned, _made

from api.cli.main import app
from api.services.fleet_models import exclude_from_fleet, include_in_fleet
from api.services.plans import create_plan, replan
from api.services.read.fleet import fleet_members
from db import tables as t
from db.fleet import fleet_evidence

from conftest import engine_url


def _plans_behind(engine, name: str) -> list[str]:  # type: ignore[no-untyped-def]
    made = create_plan(engine=engine, body=_body(name, f"lathe-{name}"), settings=LEARN).body
    if made["prior"] == "catalogue":
        return []
    return made["provenance"]["rough-od"][0]["plans"]


def test_an_excluded_plan_or_machine_leaves_the_prior_and_comes_back(engine) -> None:
    a = _learned(engine, "fleet-a", 0, 3)
    _learned(engine, "fleet-b", 1, 3)
    assert _plans_behind(engine, "c1") == ["fleet-a", "fleet-b"]
    exclude_from_fleet(engine=engine, plan_id=a, machine=None, reason="wrong bar stock")
    assert _plans_behind(engine, "c2") == ["fleet-b"]
    exclude_from_fleet(engine=engine, plan_id=None, machine="lathe-1", reason="loose spindle")
    assert _plans_behind(engine, "c3") == []  # nothing left: the catalogue
    include_in_fleet(engine=engine, plan_id=None, machine="lathe-1")
    include_in_fleet(engine=engine, plan_id=a, machine=None)
    assert _plans_behind(engine, "c4") == ["fleet-a", "fleet-b"]
    with Session(engine) as session:
        reasons = set(session.scalars(select(t.AuditEntry.action)))
    assert {"fleet exclude", "fleet include"} <= reasons


def _count_change(engine, plan_id: int) -> None:  # type: ignore[no-untyped-def]
    """One more change counted by ``plan_id``'s newest monitor (as a part report would)."""
    with Session(engine) as session, session.begin():
        newest = session.scalars(
            select(t.BandState)
            .join(t.Operation, t.BandState.operation_id == t.Operation.id)
            .where(t.Operation.plan_id == plan_id)
            .order_by(t.BandState.id.desc())
        ).first()
        assert newest is not None and newest.monitor is not None
        newest.monitor = {**newest.monitor, "changes": newest.monitor.get("changes", 0) + 1}


def test_a_plan_whose_process_changed_is_out_until_an_engineer_accepts_it(engine) -> None:
    a = _learned(engine, "fleet-a", 0, 3)
    _learned(engine, "fleet-b", 1, 3)
    _count_change(engine, a)  # a change counted by a's monitor
    assert _plans_behind(engine, "c1") == ["fleet-b"]
    done = include_in_fleet(engine=engine, plan_id=a, machine=None)
    assert done.body["changes_accepted"] == 1
    assert _plans_behind(engine, "c2") == ["fleet-a", "fleet-b"]


def test_an_exclusion_does_not_hide_a_change_and_include_says_what_it_accepted(engine) -> None:
    """A process engineer's review: a plan taken out then changed said only "taken out by ...",
    and ``rcb fleet include`` then accepted the change unseen; it said the running total of
    accepted changes (the same count again after an exclude and include with none new)."""
    a = _learned(engine, "fleet-a", 0, 3)
    exclude_from_fleet(engine=engine, plan_id=a, machine=None, reason="check spindle")
    _count_change(engine, a)
    out = fleet_members(engine=engine, tool="VCMR331")["plans"][0]["out"]
    assert out.startswith("taken out by cli") and "check spindle; also its process changed" in out
    assert include_in_fleet(engine=engine, plan_id=a, machine=None).body["changes_accepted"] == 1
    exclude_from_fleet(engine=engine, plan_id=a, machine=None, reason="again")
    again = include_in_fleet(engine=engine, plan_id=a, machine=None).body
    assert (again["put_back"], again["changes_accepted"]) == (True, 0)  # was 1 again
    _count_change(engine, a)
    assert include_in_fleet(engine=engine, plan_id=a, machine=None).body["changes_accepted"] == 1


def test_rcb_fleet_at_the_cli_names_what_is_wrong(engine, runner) -> None:
    _learned(engine, "fleet-a", 0, 2)
    url = engine_url(engine)
    done = runner.invoke(
        app, ["fleet", "exclude", "--plan", "fleet-a", "--reason", "r", "--db", url]
    )
    assert done.exit_code == 0 and "plan 1 is out of the fleet (r)" in done.output
    done = runner.invoke(app, ["fleet", "exclude", "--reason", "r", "--db", url])
    assert done.exit_code == 2 and "name exactly one of a plan and a machine" in done.output
    done = runner.invoke(
        app, ["fleet", "exclude", "--machine", "nope", "--reason", "r", "--db", url]
    )
    assert done.exit_code == 2 and "--machine = 'nope'" in done.output
    done = runner.invoke(app, ["fleet", "exclude", "--plan", "99", "--reason", "r", "--db", url])
    assert done.exit_code == 2 and "--plan = 99: no such plan" in done.output  # not "concurrent"
    for blank in ("", "  "):
        done = runner.invoke(
            app, ["fleet", "exclude", "--plan", "fleet-a", "--reason", blank, "--db", url]
        )
        assert done.exit_code == 2 and "--reason" in done.output and "give why" in done.output
    done = runner.invoke(
        app, ["fleet", "exclude", "--plan", "fleet-a", "--reason", "x" * 501, "--db", url]
    )
    assert done.exit_code == 2 and "1 to 500 characters" in done.output
    done = runner.invoke(
        app, ["fleet", "exclude", "--plan", "fleet-a", "--reason", " chipped ", "--db", url]
    )  # again: one exclusion, its reason the newest, the one it replaces said
    said = " ".join(done.output.split())
    assert done.exit_code == 0 and "plan 1 was already out of the fleet (taken out by" in said
    assert ": r); its reason is now: chipped" in said
    with Session(engine) as session:
        assert list(session.scalars(select(t.FleetExclusion.reason))) == ["chipped"]
    done = runner.invoke(app, ["fleet", "include", "--plan", "fleet-a", "--db", url])
    assert done.exit_code == 0 and "plan 1 is back in the fleet" in done.output


def _count_changes(engine, plan_id: int, op: str, changes: int) -> None:  # type: ignore[no-untyped-def]
    """The newest monitor of ``op``'s first quantity has counted ``changes``."""
    with Session(engine) as session, session.begin():
        newest = session.scalars(
            select(t.BandState)
            .join(t.Operation, t.BandState.operation_id == t.Operation.id)
            .where(t.Operation.plan_id == plan_id, t.Operation.name == op)
            .order_by(t.BandState.id.desc())
        ).first()
        assert newest is not None and newest.monitor is not None
        newest.monitor = {**newest.monitor, "changes": changes}


def _in_fleet(engine, tool: str) -> set[str]:  # type: ignore[no-untyped-def]
    with Session(engine) as session:
        return {item.plan for item in fleet_evidence(session=session, tool_names=[tool])}


def test_a_change_after_those_accepted_takes_the_plan_out_whatever_tool_asks(engine) -> None:
    """Changes are counted over the whole plan, as an engineer accepts them: with one change
    on rough-od's insert and one on rough-grooves' accepted, a second on rough-od's is not
    (before, a plan asking only for CNMG432RN counted 2 changes against 2 accepted)."""
    a = _learned(engine, "fleet-a", 0, 3)
    _count_changes(engine, a, "rough-od", 1)
    _count_changes(engine, a, "rough-grooves", 1)
    assert _in_fleet(engine, "CNMG432RN") == _in_fleet(engine, "VCMR331") == set()
    assert include_in_fleet(engine=engine, plan_id=a, machine=None).body["changes_accepted"] == 2
    assert _in_fleet(engine, "CNMG432RN") == {"fleet-a"}
    _count_changes(engine, a, "rough-od", 2)
    assert _in_fleet(engine, "CNMG432RN") == _in_fleet(engine, "VCMR331") == set()


def test_a_reset_of_the_bands_starts_the_count_of_changes_again(engine) -> None:
    """``rcb replan --reset-bands`` forgets the monitors and what the plan learned: the plan's
    models are out of the fleet until a part after it (nothing learned since), its accepted
    changes count from 0 again, and a change after it takes the plan out."""
    a = _learned(engine, "fleet-a", 0, 3)
    _count_changes(engine, a, "rough-od", 1)
    include_in_fleet(engine=engine, plan_id=a, machine=None)
    assert _in_fleet(engine, "CNMG432RN") == {"fleet-a"}
    assert replan(engine=engine, plan_id=a, changes={"reset_bands": True}).status == 201
    assert _in_fleet(engine, "CNMG432RN") == set()  # nothing learned since the reset
    _made(engine, a, 0, "fleet-a-r", 2)
    assert _in_fleet(engine, "CNMG432RN") == {"fleet-a"}
    _count_changes(engine, a, "rough-od", 1)
    assert _in_fleet(engine, "CNMG432RN") == set()
