"""Which plans make the fleet (issue 32): an engineer takes a plan or a machine out and puts it
back; a plan whose process changed is out by itself until then (SQLite and PostgreSQL)."""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import Session
from test_fleet_db import LEARN, _body, _learned

from api.cli.main import app
from api.services.fleet_models import exclude_from_fleet, include_in_fleet
from api.services.plans import create_plan
from db import tables as t


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


def test_a_plan_whose_process_changed_is_out_until_an_engineer_accepts_it(engine) -> None:
    a = _learned(engine, "fleet-a", 0, 3)
    _learned(engine, "fleet-b", 1, 3)
    with Session(engine) as session, session.begin():  # a change counted by a's monitor
        newest = session.scalars(
            select(t.BandState)
            .join(t.Operation, t.BandState.operation_id == t.Operation.id)
            .where(t.Operation.plan_id == a)
            .order_by(t.BandState.id.desc())
        ).first()
        assert newest is not None and newest.monitor is not None
        newest.monitor = {**newest.monitor, "changes": 1}
    assert _plans_behind(engine, "c1") == ["fleet-b"]
    done = include_in_fleet(engine=engine, plan_id=a, machine=None)
    assert done.body["changes_accepted"] == 1
    assert _plans_behind(engine, "c2") == ["fleet-a", "fleet-b"]


def test_rcb_fleet_at_the_cli_names_what_is_wrong(engine, runner) -> None:
    _learned(engine, "fleet-a", 0, 2)
    url = engine.url.render_as_string(hide_password=False)
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
    done = runner.invoke(app, ["fleet", "include", "--plan", "fleet-a", "--db", url])
    assert done.exit_code == 0 and "plan 1 is back in the fleet" in done.output
