"""Whole passes and the rest of the system: RCB, the database, the REST schema, the CLI.

RCB runs parts of plans cut in passes (a virtual mill; ivester and learn) and reads a
finishing pass's roughness at its setpoint and limit, the force at the roughing passes'; the
passes survive the database and match the REST schema; ``rcb optimize`` prints and gives them.
"""

from __future__ import annotations

import json
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy.orm import Session

from api.cli.main import app
from api.cli.tables import fmt
from api.rest.schemas.parts import parse_report
from api.rest.schemas.plans import PlanIn
from api.rest.schemas.setpoints import OperationSetpoint
from api.services import read as queries
from api.services.parts import report_part
from api.services.plans import create_plan
from db.engine import make_engine
from db.plans import get_plan_row
from db.state import load_state
from supervisor.inputs.part_report import Measurement, PartReport
from supervisor.inputs.plan import load_plan
from supervisor.optimize.extras import extras_of, with_extras
from supervisor.optimize.optimizer import optimize_plan
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start, update
from supervisor.virtual.sampling import sample_machine
from supervisor.virtual.simulate import run_part

from migrated import migrated

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
TURNING = EXAMPLES / "turning_passes_part.toml"
MILLING = EXAMPLES / "milling_passes_part.toml"


# ---------------------------------------------------------------------------- RCB


@pytest.mark.parametrize("strategy", ["ivester", "learn"])
def test_rcb_runs_parts_of_a_plan_cut_in_passes_on_a_virtual_mill(strategy):
    plan = load_plan(MILLING)
    machine, rng = sample_machine(plan, 5), np.random.default_rng(5)
    state = start(plan, RcbSettings(strategy))
    for i in range(4):
        outcome = run_part(
            machine, {op.name: op.setpoint for op in state.setpoints.operations}, rng
        )
        assert outcome.violations == ()
        report = PartReport(f"P{i}", state.version, outcome.measurements)
        state, decisions = update(state, report)
        assert {d.operation for d in decisions} == {"slot", "side-finish"}
        slot = state.setpoints.operations[0]
        assert sum(g.count * g.depth_mm for g in slot.passes.groups) == pytest.approx(6.0)
    assert state.version > 1 and state.halt is None


def test_rcb_reads_roughness_at_the_finishing_pass_and_force_at_the_roughing_passes():
    state = start(load_plan(TURNING), RcbSettings("ivester"))
    first_feed = state.setpoints.operations[0].passes.groups[1].result.setpoint["feed_mm_rev"]
    for i in range(3):
        od = state.setpoints.operations[0]
        rough, finish = od.passes.groups
        measured = {"force_N": Measurement(1400.0, 20.0), "roughness_um": Measurement(1.0, 0.05)}
        state, decisions = update(
            state, PartReport(f"S{i}", state.version, {"od-passes": measured})
        )
        by = {d.quantity: d for d in decisions}
        assert by["roughness_um"].limit == 1.6  # the finishing pass's own limit
        assert by["roughness_um"].predicted == pytest.approx(
            finish.result.predicted["roughness_um"].value
        )
        assert by["force_N"].limit == 2000
        assert by["force_N"].predicted == pytest.approx(rough.result.predicted["force_N"].value)
        assert by["roughness_um"].action == "shrink" and not by["roughness_um"].flagged
    # the finish's roughness band shrank (1.0 + 0.05 µm against 1.6 µm): a faster finish
    finish_feed = state.setpoints.operations[0].passes.groups[1].result.setpoint["feed_mm_rev"]
    assert finish_feed > first_feed


# ---------------------------------------------------------------------------- storage, REST


def test_passes_survive_the_database_and_match_the_rest_schema(tmp_path):
    body = tomllib.loads(TURNING.read_text(encoding="utf-8"))
    PlanIn.model_validate(body)  # the REST body accepts stock_mm and finish
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    try:
        settings_ = RcbSettings("ivester")
        created = create_plan(engine=engine, body=body, settings=settings_).body
        plan_id = created["id"]
        part = {
            "serial": "S1",
            "setpoint_version": 1,
            "operations": [
                {
                    "name": "od-passes",
                    "measurements": {
                        "force_N": {"value": 1400, "uncertainty": 20},
                        "roughness_um": {"value": 1.0, "uncertainty": 0.05},
                    },
                }
            ],
        }
        report_part(engine=engine, plan_id=plan_id, report=parse_report(part))
        current = queries.current_setpoints(engine=engine, plan_id=plan_id)
        od = current["operations"][0]
        OperationSetpoint.model_validate(od)
        assert od["passes"]["count"] == 3
        assert [g["kind"] for g in od["passes"]["groups"]] == ["roughing", "finishing"]
        with Session(engine) as session:
            stored = load_state(
                session=session, plan_row=get_plan_row(session=session, plan_id=plan_id)
            )
        replayed = start(load_plan(TURNING), settings_)
        replayed, _ = update(
            replayed,
            PartReport(
                "S1",
                1,
                {
                    "od-passes": {
                        "force_N": Measurement(1400, 20),
                        "roughness_um": Measurement(1.0, 0.05),
                    }
                },
            ),
        )
        for a, b in zip(stored.setpoints.operations, replayed.setpoints.operations, strict=True):
            for ga, gb in zip(a.passes.groups, b.passes.groups, strict=True):
                assert (ga.kind, ga.count) == (gb.kind, gb.count)
                assert ga.result.setpoint == pytest.approx(gb.result.setpoint)
                assert ga.result.time_min == pytest.approx(gb.result.time_min)
    finally:
        engine.dispose()


def test_extras_round_trip_keeps_every_pass():
    result = optimize_plan(load_plan(TURNING)).operations[0]
    base = replace(result, passes=None)
    back = with_extras(base, extras_of(result))
    assert back.passes.count == result.passes.count
    for a, b in zip(back.passes.groups, result.passes.groups, strict=True):
        assert (a.kind, a.count, a.depth_mm) == (b.kind, b.count, b.depth_mm)
        assert a.result.setpoint == b.result.setpoint
        assert a.result.predicted == b.result.predicted
        assert (a.result.time_min, a.result.binding) == (b.result.time_min, b.result.binding)


def test_rcb_optimize_prints_the_passes_and_gives_them_in_json(runner):
    shown = runner.invoke(app, ["optimize", str(TURNING)])
    given_ = runner.invoke(app, ["optimize", str(TURNING), "--json"])
    assert shown.exit_code == 0 and given_.exit_code == 0, shown.output + given_.output
    od = json.loads(given_.stdout)["operations"][0]
    assert od["passes"]["count"] == 3 and od["passes"]["stock_mm"] == 5.0
    rough, finish = od["passes"]["groups"]
    assert (rough["kind"], rough["count"], finish["kind"]) == ("roughing", 2, "finishing")
    assert "od-passes: 3 passes cut stock_mm = 5" in shown.stdout
    for group in (rough, finish):  # each pass's setpoint and time appear in the table
        for value in (*group["setpoint"].values(), group["time_min"], group["mrr_cm3_min"]):
            assert fmt(value) in shown.stdout
