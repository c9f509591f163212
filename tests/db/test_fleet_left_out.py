"""A new plan's fleet prior says what the fleet left out of its tool's plans (issue 32), and
checks the band's optimum at 2 sd where one of them halted.

A review: a prior read "from 1 plan on 1 machine" where three newer plans of the tool were
out of the fleet (halted, taken out, changed), and only ``rcb fleet show TOOL`` said so; the
engineer creating the plan could not tell a fleet's one plan from a fleet whose other plans
had been left out. Now each prior's provenance counts them, by their first reason, on every
surface: the JSON (REST, ``--json``), its line, ``rcb plans show``'s table and the report.
SQLite and PostgreSQL.
"""

from __future__ import annotations

import json

from test_fleet_db import _body, _learned
from test_fleet_exclusions import _count_change

from api.cli.main import app
from api.report.provenance import prior_line
from api.rest.schemas.parts import parse_report
from api.rest.schemas.setpoints import PriorProvenance
from api.services.fleet_models import exclude_from_fleet
from api.services.parts import report_part
from api.services.plans import create_plan
from db.fleet_names import bounded
from supervisor.rcb.state import RcbSettings

from conftest import engine_url, stored_state

LEARN = RcbSettings(strategy="learn")
#: What the new plan's lines say of the three plans left out (each quantity of each tool).
SAID = "3 plans of its tool left out (1 halted, 1 taken out, 1 changed)"


def _halt(engine, plan_id: int) -> None:  # type: ignore[no-untyped-def]
    """``plan_id`` halted by a part: rough-od's force at three times its 2000 N limit."""
    version = stored_state(engine, plan_id).version
    force = {"force_N": {"value": 6000.0, "uncertainty": 10.0}}
    body = {
        "serial": f"halt-{plan_id}",
        "setpoint_version": version,
        "operations": [{"name": "rough-od", "measurements": force}],
    }
    answer = report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
    assert answer.status == 201 and answer.body["halted"] is True, answer.body


def _lines(plan: dict) -> list[dict]:  # type: ignore[type-arg]
    return [p for ps in plan["provenance"].values() for p in ps]


def test_a_new_plan_counts_the_plans_left_out_by_why(engine, runner) -> None:
    _learned(engine, "fleet-a", 0, 3)
    halted = _learned(engine, "fleet-b", 1, 3)
    taken = _learned(engine, "fleet-c", 2, 3)
    changed = _learned(engine, "fleet-d", 3, 3)
    before = create_plan(engine=engine, body=_body("new-0", "lathe-5"), settings=LEARN).body
    assert {json.dumps(p["left_out"]) for p in _lines(before)} == {
        json.dumps({"taken_out": 0, "halted": 0, "changed": 0})
    }
    assert not any("left out" in p["text"] for p in _lines(before))
    assert {p["band_checked_at_sd"] for p in _lines(before)} == {None}  # 3 % apart: the mean
    assert all(p["band_checked_because"] == [] for p in _lines(before))
    _halt(engine, halted)
    exclude_from_fleet(engine=engine, plan_id=taken, machine=None, reason="1040 bar")
    _count_change(engine, changed)
    # the halted plan also counted a change: it counts once, by its first reason
    _count_change(engine, halted)
    plan = create_plan(engine=engine, body=_body("new-1", "lathe-6"), settings=LEARN).body
    lines = _lines(plan)
    assert {p["plans_total"] for p in lines} == {1}  # fleet-a alone
    assert all(p["left_out"] == {"taken_out": 1, "halted": 1, "changed": 1} for p in lines)
    # a plan of each tool halted: the band's optimum is checked at 2 sd (prior._prior)
    assert {p["band_checked_at_sd"] for p in lines} == {2.0}
    assert all(p["band_checked_because"] == ["halted"] for p in lines)  # 3 % apart: no spread
    assert all("a plan of its tool halted: checked at 2 sd" in p["text"] for p in lines)
    assert all(p["text"].endswith(f"2 sd; {SAID}: rcb fleet show says why") for p in lines)
    for line in lines:  # what REST declares
        assert PriorProvenance.model_validate(bounded(line)).left_out is not None
    # the report's overview and rcb plans show, per operation (each its own tool)
    tools = dict.fromkeys(op["tool"] for op in plan["operations"])
    counted = "3 plans (1 halted, 1 taken out, 1 changed)"
    each = (
        f"left out of the fleet: {', '.join(f'{tool} {counted}' for tool in tools)} (rcb "
        "fleet show TOOL says which and why)"
    )
    assert each in prior_line(plan)
    halted_said = "a plan of its tool halted, so the catalogue band's setpoint runs only where"
    assert halted_said in prior_line(plan) and "differ by more" not in prior_line(plan)
    shown = runner.invoke(app, ["plans", "show", str(plan["id"]), "--db", engine_url(engine)])
    assert shown.exit_code == 0, shown.output
    assert each in " ".join(shown.output.split())


def test_a_plan_that_learns_nothing_is_not_counted(engine) -> None:
    """An ``ivester`` plan was never the fleet's: halted, it is not left out of it."""
    _learned(engine, "fleet-a", 0, 3)
    other = create_plan(
        engine=engine,
        body=_body("fixed", "lathe-1"),
        settings=RcbSettings(strategy="ivester"),
    ).body
    _halt(engine, int(other["id"]))
    plan = create_plan(engine=engine, body=_body("new", "lathe-2"), settings=LEARN).body
    assert all(sum(p["left_out"].values()) == 0 for p in _lines(plan))
    assert {p["band_checked_at_sd"] for p in _lines(plan)} == {None}
    assert "left out" not in prior_line(plan)


def test_a_prior_stored_before_they_were_counted_says_nothing_of_them() -> None:
    """A provenance without ``left_out`` (stored before it was kept): null over REST, no words."""
    stored = {
        "quantity": "force_N",
        "plans": ["a"],
        "machines": ["m"],
        "between_machine_spread": 0.03,
        "readings": 4,
        "text": "force_N: prior from 1 plan on 1 machine",
    }
    assert PriorProvenance.model_validate(bounded(stored)).left_out is None
    plan = {"prior": "fleet", "operations": [{"name": "op"}], "provenance": {"op": [stored]}}
    assert "left out" not in prior_line(plan)
