"""Replanning by an engineer: service (SQLite, PostgreSQL), REST and CLI."""

from __future__ import annotations

import json

import pytest
from sqlalchemy import func, select
from sqlalchemy.orm import Session
from test_service import BODY, _reports

from api.cli.main import app
from api.rest.schemas.parts import parse_report
from api.services import read as queries
from api.services.parts import report_part
from api.services.plans import create_plan, replan
from db import tables as t
from db.engine import make_engine
from db.plans import get_plan_row
from db.state import load_state
from supervisor.errors import InfeasibleError
from supervisor.rcb.state import RcbSettings

from migrated import migrated


def _count(engine, table):
    with Session(engine) as session:
        return session.scalar(select(func.count()).select_from(table))


def _state(engine, plan_id):
    with Session(engine) as session, session.begin():
        row = get_plan_row(session=session, plan_id=plan_id, lock=True)
        return load_state(session=session, plan_row=row)


def test_a_relaxed_limit_is_stored_as_a_replan_version_and_a_dry_run_stores_nothing(engine):
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    change = {"limits": {"rough-od.force_N": 2200}}
    dry = replan(engine=engine, plan_id=plan_id, changes=change, dry_run=True)
    assert dry.status == 200 and dry.body["dry_run"] and dry.body["setpoint_version"] == 1
    assert _count(engine, t.PlanRevision) == 0 and _count(engine, t.SetpointVersion) == 1
    done = replan(engine=engine, plan_id=plan_id, changes=change)
    assert done.status == 201 and done.body["setpoint_version"] == 2
    assert done.body["operations"] == dry.body["operations"]
    rough = done.body["diff"][0]
    assert rough["operation"] == "rough-od"
    # Table 5 step 1 R (191.2 cm³/min, force and roughness binding) → force no longer binds:
    # depth rises to its 3.0 mm bound
    assert rough["mrr_cm3_min"][0] == pytest.approx(191.2, rel=0.005)
    assert rough["mrr_cm3_min"][1] > rough["mrr_cm3_min"][0]
    assert "force_N" not in rough["binding"][1] and "depth_mm" in rough["binding"][1]
    history = queries.plan_history(engine=engine, plan_id=plan_id)["versions"]
    assert [(v["version"], v["cause"]) for v in history] == [(1, "initial"), (2, "replan")]
    plan = queries.get_plan(engine=engine, plan_id=plan_id)
    assert plan["body"]["operations"][0]["limits"]["force_N"] == 2200
    with Session(engine) as session:
        audit = session.scalars(select(t.AuditEntry).where(t.AuditEntry.action == "replan")).all()
    assert [(a.actor, a.result) for a in audit] == [("cli", "201")]


def test_a_model_change_and_a_band_reset_are_new_model_versions(engine):
    ivester = RcbSettings(strategy="ivester")  # the paper's law narrows the band in force
    plan_id = create_plan(engine=engine, body=BODY, settings=ivester).body["id"]
    bodies, _ = _reports(4, settings=ivester)  # made at its own setpoints
    for body in bodies:
        report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
    shrunk = _state(engine, plan_id)
    baseline = shrunk.plan.tools["CNMG432RN"].models["force_N"]
    assert shrunk.tools["rough-od"].models["force_N"].dK < baseline.dK  # RCB narrowed it
    changed = {"models": {"CNMG432RN.force_N": {"dK": 100.0}}}
    replan(engine=engine, plan_id=plan_id, changes=changed)
    after = _state(engine, plan_id)
    assert after.tools["rough-od"].models["force_N"].dK == 100.0
    assert (
        after.tools["rough-od"].models["force_N"].K == shrunk.tools["rough-od"].models["force_N"].K
    )
    assert after.tools["rough-grooves"] == shrunk.tools["rough-grooves"]  # another insert
    replan(engine=engine, plan_id=plan_id, changes={"reset_bands": True})
    reset = _state(engine, plan_id)
    for name, tool in reset.tools.items():
        assert tool == reset.plan.tools[tool.name], name  # back to the baseline models
    assert reset.seen == {}
    versions = queries.model_versions(
        engine=engine, plan_id=plan_id, operation="rough-od", quantity="force_N"
    )["versions"]
    assert [v["cause"] for v in versions][-2:] == ["replan", "replan"]
    assert versions[-2]["dK"] == 100.0 and versions[-1]["dK"] == baseline.dK
    # RCB goes on from the reset state
    more, _ = _reports(6)
    late = {**more[5], "serial": "AFTER-RESET", "setpoint_version": reset.version}
    answer = report_part(engine=engine, plan_id=plan_id, report=parse_report(late)).body
    assert answer["setpoint_version"] >= reset.version


def test_a_model_change_that_learns_readings_would_hide_is_refused_and_a_reset_takes_it(engine):
    """A learn plan's setpoints follow what its readings taught: a new K for a model it has
    readings of would be stored and change nothing (a reviewer's K=2600 on rough-od's force
    left every setpoint as it was). It is refused, naming the model and the way to apply it;
    with reset_bands it is the new start."""
    plan_id = create_plan(engine=engine, body=BODY).body["id"]  # learn, the default
    bodies, _ = _reports(3)
    for body in bodies:
        report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
    change = {"models": {"CNMG432RN.force_N": {"K": 2600.0}}}
    with pytest.raises(ValueError, match=r"models\.CNMG432RN\.force_N.*its 3 readings govern"):
        replan(engine=engine, plan_id=plan_id, changes=change)
    assert _count(engine, t.PlanRevision) == 0  # nothing stored
    before = _state(engine, plan_id).setpoints.cycle_time_min
    done = replan(engine=engine, plan_id=plan_id, changes={**change, "reset_bands": True})
    after = _state(engine, plan_id)
    assert after.tools["rough-od"].models["force_N"].K == 2600.0
    assert ("rough-od", "force_N") not in after.posterior  # learning starts again
    # a larger K (more force predicted) at the same limit: a slower plan
    assert done.body["cycle_time_min"] == [pytest.approx(before), after.setpoints.cycle_time_min]
    assert after.setpoints.cycle_time_min > before
    # a model no reading taught yet (a fresh plan) takes the change as before
    fresh = create_plan(engine=engine, body={**BODY, "name": "fresh"}).body["id"]
    taken = replan(engine=engine, plan_id=fresh, changes=change).body
    assert taken["cycle_time_min"][1] > taken["cycle_time_min"][0]


def test_bad_changes_are_refused_and_nothing_is_stored(engine):
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    with pytest.raises(ValueError, match="limits.rough-odd.force_N"):
        replan(engine=engine, plan_id=plan_id, changes={"limits": {"rough-odd.force_N": 1}})
    with pytest.raises(ValueError, match="models.NOPE.force_N"):
        replan(engine=engine, plan_id=plan_id, changes={"models": {"NOPE.force_N": {"K": 1}}})
    # named by the change's path, not the plan's (operations[0].bounds.depth_mm): a review
    for where, key, value in [
        ("bounds", "rough-od.depth_mm", [3, 1]),
        ("limits", "rough-od.forse_N", 1),  # an unknown quantity
        ("bounds", "rough-od.depht_mm", [1, 2]),  # an unknown parameter
        ("limits", "finish-od.roughness_um", -1.5),  # the second operation's
    ]:
        with pytest.raises(ValueError) as refused:
            replan(engine=engine, plan_id=plan_id, changes={where: {key: value}})
        assert (refused.value.field, refused.value.value) == (f"{where}.{key}", value)
    with pytest.raises(InfeasibleError):
        replan(engine=engine, plan_id=plan_id, changes={"limits": {"rough-od.force_N": 10}})
    with pytest.raises(ValueError, match="nothing to change"):
        replan(engine=engine, plan_id=plan_id, changes={})
    assert _count(engine, t.PlanRevision) == 0 and _count(engine, t.SetpointVersion) == 1


def test_replan_over_rest(server):
    with server.client("engineer") as c, server.client("viewer") as v:
        plan_id = c.post("/plans", json=BODY).json()["id"]
        change = {"limits": {"rough-od.force_N": 2200}}
        dry = c.post(f"/plans/{plan_id}/replan", params={"dry_run": True}, json=change)
        assert dry.status_code == 200 and dry.json()["dry_run"]
        done = c.post(f"/plans/{plan_id}/replan", json=change, headers={"Idempotency-Key": "r1"})
        assert done.status_code == 201 and done.json()["setpoint_version"] == 2
        again = c.post(f"/plans/{plan_id}/replan", json=change, headers={"Idempotency-Key": "r1"})
        assert again.json() == done.json() and again.headers["Idempotent-Replayed"] == "true"
        assert c.get(f"/plans/{plan_id}/setpoints").json()["setpoint_version"] == 2
        bad = c.post(f"/plans/{plan_id}/replan", json={"limits": {"rough-od.force_N": 10}})
        assert bad.status_code == 422 and bad.json()["code"] == "infeasible"
        negative = c.post(f"/plans/{plan_id}/replan", json={"limits": {"rough-od.force_N": -5}})
        assert negative.headers["content-type"] == "application/problem+json"
        assert (negative.status_code, negative.json()["field"]) == (422, "limits.rough-od.force_N")
        assert v.post(f"/plans/{plan_id}/replan", json=change).status_code == 403


def _replan_args(tmp_path) -> tuple[str, list[str]]:  # type: ignore[no-untyped-def]
    """A database with the demonstration plan, and ``rcb replan``'s first arguments on it."""
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    engine.dispose()
    return url, ["replan", str(plan_id), "--db", url]


def test_rcb_replan(runner, tmp_path):
    url, args = _replan_args(tmp_path)
    dry = runner.invoke(app, [*args, "--limit", "rough-od.force_N=2200", "--dry-run", "--json"])
    assert dry.exit_code == 0, dry.output
    assert json.loads(dry.stdout)["setpoint_version"] == 1
    done = runner.invoke(
        app,
        [*args, "--bound", "rough-od.depth_mm=0.5:2.5", "--model", "CNMG432RN.force_N:dK=120"],
    )
    assert done.exit_code == 0, done.output
    assert "stored as setpoint version 2" in done.stderr
    for bad, message in [
        (["--bound", "rough-od.depth_mm=1-2"], "--bound rough-od.depth_mm = '1-2'"),
        (["--model", "CNMG432RN.force_N"], "--model = 'CNMG432RN.force_N'"),
        (["--limit", "rough-od.force_N=lots"], "--limit rough-od.force_N = 'lots'"),
        # named by the option, not the plan's operations[0].limits.force_N (a review)
        (["--limit", "rough-od.force_N=1e309"], "--limit rough-od.force_N = inf"),
        (["--limit", "rough-od.force_N=-5"], "--limit rough-od.force_N = -5.0"),
        (["--bound", "rough-od.depth_mm=3:1"], "--bound rough-od.depth_mm = [3.0, 1.0]"),
        (["--limit", "nope.force_N=5"], "--limit nope.force_N = 'nope'"),
        (["--model", "CNMG432RN.force_N:K=-3"], "--model CNMG432RN.force_N.K = -3.0"),
        (["--limit", "rough-od.force_N=10"], "infeasible"),
    ]:
        result = runner.invoke(app, [*args, *bad])
        assert result.exit_code in (2, 3) and message in result.stderr, result.output
        assert "Traceback" not in result.output


def test_a_dry_run_leaves_no_audit_entry_refused_or_not(runner, tmp_path):
    """A process engineer's review: 17 what-if ``--dry-run`` replans that were refused read in
    ``rcb audit`` as 17 refused replans (with ``field: ,``), while accepted ones left nothing.
    A dry run stores nothing and is not audited; a refused replan is, without an empty field."""
    url, args = _replan_args(tmp_path)
    for change in (["--limit", "rough-od.force_N=10"], ["--bound", "rough-od.depth_mm=3:1"]):
        result = runner.invoke(app, [*args, *change, "--dry-run"])
        assert result.exit_code in (2, 3), result.output
    audit = ["audit", "--action", "replan", "--db", url]
    assert json.loads(runner.invoke(app, [*audit, "--json"]).stdout)["entries"] == []
    refused = runner.invoke(app, [*args, "--limit", "rough-od.force_N=10"])
    assert refused.exit_code == 3, refused.output
    [entry] = json.loads(runner.invoke(app, [*audit, "--json"]).stdout)["entries"]
    assert (entry["result"], entry["detail"]["error"]) == ("refused", "InfeasibleError")
    shown = runner.invoke(app, [*audit, "--limit", "5"]).stdout
    assert "InfeasibleError," in shown and "message:" in shown
    assert "field:" not in shown  # no field to name: not "field: ,"
