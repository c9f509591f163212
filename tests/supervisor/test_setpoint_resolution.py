"""Setpoints are machine values: within their bounds, on the machine's resolution grid, safe.

The rule (:mod:`supervisor.optimize.grid`): the best grid neighbour of the continuous optimum
that meets every robust row, else the best neighbour of the tightened program's optimum; the
predictions are those of the grid point. The grid is ``[machine.resolution]`` of the plan
(:mod:`supervisor.inputs.resolution`). Checked here on plan files, on random plans
(Hypothesis), on the learn strategy's cone setpoints, milling and constant-load plans, the
virtual machine's oracle, the CLI and the REST service; on hand-made programs in
test_setpoint_grid_rule.py.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from grid_support import on_grid, steps
from hypothesis import event, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from property_support import Scenario, robust_edges, scenarios

from api.cli.main import app
from models import kinematics
from models.errors import InputError
from models.tool import predict_all
from supervisor.errors import InfeasibleError, PlanError
from supervisor.inputs.part_report import PartReport
from supervisor.inputs.plan import load_plan, plan_from_mapping
from supervisor.inputs.resolution import DEFAULT_RESOLUTION
from supervisor.optimize.formulation import formulate
from supervisor.optimize.optimizer import optimize_plan
from supervisor.optimize.result import PlanResult
from supervisor.optimize.solve import optimum
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start, update
from supervisor.virtual.sampling import oracle_tools, sample_machine
from supervisor.virtual.simulate import run_part

from conftest import DEMO_PLAN, ROOT, step1_plan
from live import LiveServer

EXAMPLES = ROOT / "examples"
#: A re-computed band edge may pass its limit by this fraction (float rounding only: the
#: grid point is checked against every row to 1e-12 in ln).
LIMIT_RTOL = 1e-9
STEP1 = step1_plan()  # the machine's default resolution


def check_machine_values(result: PlanResult, plan: Any) -> None:
    """Every setpoint within its bounds exactly, on the grid, with predictions recomputed."""
    resolution = plan.machine.resolution
    for op, r in zip(plan.operations, result.operations, strict=True):
        for p, v in r.setpoint.items():
            low, high = op.bounds[p]
            assert low <= v <= high, (op.name, p, v)
            assert on_grid(v, resolution[p]) or low == v == high, (op.name, p, v)
        point = {**r.setpoint, **op.context}
        assert_allclose(
            r.mrr_cm3_min, kinematics.mrr_monomial(op.process).evaluate(point), rtol=1e-12
        )
        if r.robust_by == "band":
            expected = predict_all(r.tool_models, point, op.setpoint_rel_uncertainty)
            assert dict(r.predicted) == expected, op.name


# --------------------------------------------------------------------------- plan files


def test_resolution_defaults_and_what_a_plan_gives():
    assert plan_from_mapping(STEP1).machine.resolution == DEFAULT_RESOLUTION
    data = copy.deepcopy(STEP1)
    data["machine"]["resolution"] = {"feed_mm_rev": 0.01, "speed_m_min": 5}
    machine = plan_from_mapping(data).machine
    assert machine.resolution == {**DEFAULT_RESOLUTION, "feed_mm_rev": 0.01, "speed_m_min": 5.0}


@pytest.mark.parametrize(
    ("table", "field"),
    [
        ({"depth_mm": 0}, "machine.resolution.depth_mm"),
        ({"depth_mm": -0.001}, "machine.resolution.depth_mm"),
        ({"feed_mm_rev": "0.001"}, "machine.resolution.feed_mm_rev"),
        ({"speed_m_min": 1e-12}, "machine.resolution.speed_m_min"),
        ({"speed_m_min": True}, "machine.resolution.speed_m_min"),
        ({"depth": 0.001}, "machine.resolution.depth"),
        ([0.001], "machine.resolution"),
    ],
)
def test_a_bad_resolution_is_refused_naming_its_field(table, field):
    data = copy.deepcopy(STEP1)
    data["machine"]["resolution"] = table
    with pytest.raises(InputError) as info:
        plan_from_mapping(data)
    assert info.value.field == field


def test_bounds_that_hold_no_grid_point_are_refused_naming_the_bound():
    data = copy.deepcopy(STEP1)
    data["operations"][0]["bounds"]["speed_m_min"] = [150.2, 150.7]
    with pytest.raises(PlanError) as info:
        plan_from_mapping(data)
    assert info.value.field == "operations[0].bounds.speed_m_min"
    assert "machine.resolution.speed_m_min" in str(info.value)
    data["machine"]["resolution"] = {"speed_m_min": 0.5}  # 150.5 is on this grid
    assert optimize_plan(plan_from_mapping(data)).operations[0].setpoint["speed_m_min"] == 150.5


def test_a_parameter_the_plan_fixes_keeps_its_value_off_the_grid():
    # a speed fixed at 150.25 m/min (no multiple of the 1 m/min default) is what the plan
    # means: loaded, kept exactly, the other parameters on the grid; and a plan stored before
    # the grid existed still loads
    data = copy.deepcopy(STEP1)
    data["operations"][0]["bounds"]["speed_m_min"] = [150.25, 150.25]
    plan = plan_from_mapping(data)
    result = optimize_plan(plan)
    assert result.operations[0].setpoint["speed_m_min"] == 150.25
    check_machine_values(result, plan)


def test_the_cli_refuses_a_bad_resolution_naming_it(runner, tmp_path: Path):
    plan = tmp_path / "bad.toml"
    text = DEMO_PLAN.read_text(encoding="utf-8")
    plan.write_text(text.replace("[machine]\n", "[machine]\nresolution = { depth_mm = -1 }\n"))
    result = runner.invoke(app, ["optimize", str(plan)])
    assert result.exit_code not in (0, 1), result.output
    assert "machine.resolution.depth_mm" in result.output
    assert "Traceback" not in result.output


# --------------------------------------------------------------------------- plans


def test_step1_is_the_best_grid_neighbour_of_table5_row_r():
    # the continuous optimum d 2.94371, f 0.324811, v 200 (Ivester & Heigel Table 5 step 1 R)
    # rounds down to the grid; one step more depth or feed breaks the force or roughness limit
    plan = plan_from_mapping(STEP1)
    op = optimize_plan(plan).operations[0]
    assert op.setpoint == {"depth_mm": 2.943, "feed_mm_rev": 0.3248, "speed_m_min": 200.0}
    assert op.predicted["force_N"].upper <= 2000.0
    assert op.predicted["roughness_um"].upper <= 4.0
    tool = plan.tools["CNMG432RN"]
    context = plan.operations[0].context
    for p, step in (("depth_mm", 0.001), ("feed_mm_rev", 0.0001)):
        up = {**op.setpoint, p: op.setpoint[p] + step, **context}
        predicted = predict_all(tool, up)
        assert predicted["force_N"].upper > 2000.0 or predicted["roughness_um"].upper > 4.0


def _with_resolution(sc: Scenario, resolution: dict[str, float] | None) -> dict[str, Any]:
    data = copy.deepcopy(sc.data)  # the scenarios give a FINE resolution
    if resolution is None:
        del data["machine"]["resolution"]  # the defaults
    else:
        data["machine"]["resolution"] = resolution
    return data


@settings(max_examples=60, deadline=None)
@given(scenarios(), st.none() | steps)
def test_setpoints_of_random_plans_are_machine_values_that_keep_every_limit(sc, resolution):
    data = _with_resolution(sc, resolution)
    try:
        plan = plan_from_mapping(data)
    except PlanError as err:  # a bound pair narrower than a step
        event("bounds hold no grid point")
        assert err.field.startswith("operations[0].bounds.")
        return
    try:
        result = optimize_plan(plan)
    except InfeasibleError:
        event("infeasible")
        return
    event("solved")
    check_machine_values(result, plan)
    op = result.operations[0]
    edges = robust_edges(sc.models, op.setpoint, sc.context, sc.rel)
    for quantity, (sense, limit) in sc.limits.items():
        if sense == "max":
            assert edges[quantity] <= limit * (1 + LIMIT_RTOL), quantity
        else:
            assert edges[quantity] >= limit * (1 - LIMIT_RTOL), quantity
    # the grid point is a point of the same program: never faster than its continuous optimum
    # (the program's own optimum, not a 1e-9 grid: such steps are finer than the solver's
    # feasibility tolerance, and a plan whose limit sits exactly on a bound, as Hypothesis
    # found, then has no grid point the rule can prove safe)
    lp = formulate(plan.operations[0], plan.tools[plan.operations[0].tool], plan.machine)
    grid_x = np.log([op.setpoint[p] for p in lp.parameters])
    assert np.dot(lp.objective, grid_x) <= np.dot(lp.objective, optimum(lp)) + 1e-6


@pytest.mark.parametrize(
    "name", ["ivester_demo_part", "milling_demo_part", "tai_constant_load_part"]
)
def test_example_plans_and_their_oracles_give_machine_values(name):
    plan = load_plan(EXAMPLES / f"{name}.toml")
    check_machine_values(optimize_plan(plan), plan)
    # the oracle of `rcb demo` and the benchmarks: the same rule on the true models
    oracle = optimize_plan(plan, tools=oracle_tools(sample_machine(plan, 0)))
    check_machine_values(oracle, plan)
    if name == "tai_constant_load_part":  # reference current and feed limits at the grid point
        for r in oracle.operations:
            assert r.constant_load is not None


def test_learn_setpoints_are_machine_values_inside_their_cones():
    plan = load_plan(DEMO_PLAN)
    machine = sample_machine(plan, 3)
    rng = np.random.default_rng(3)
    state = start(plan, RcbSettings(strategy="learn"))
    cones = 0
    for k in range(8):
        setpoints = {o.name: o.setpoint for o in state.setpoints.operations}
        outcome = run_part(machine, setpoints, rng)
        assert not outcome.violations
        state, _ = update(state, PartReport(f"S-{k}", state.version, outcome.measurements))
        check_machine_values(state.setpoints, plan)
        for op, r in zip(plan.operations, state.setpoints.operations, strict=True):
            cones += r.robust_by == "cone"
            for key, limit in op.limits.items():  # as shown: learned value + cone half-width
                if key in r.predicted:
                    assert r.predicted[key].upper <= limit * (1 + LIMIT_RTOL)
    assert cones > 0  # the cone program made some of them


# --------------------------------------------------------------------------- CLI and REST


def test_the_cli_shows_the_grid_setpoints(runner):
    result = runner.invoke(app, ["optimize", str(DEMO_PLAN), "--json"])
    assert result.exit_code == 0, result.output
    ops = {op["name"]: op for op in json.loads(result.stdout)["operations"]}
    assert ops["rough-od"]["setpoint"] == {
        "depth_mm": 2.943,
        "feed_mm_rev": 0.3248,
        "speed_m_min": 200.0,
    }
    for op in ops.values():
        for p, v in op["setpoint"].items():
            assert on_grid(v, DEFAULT_RESOLUTION[p]), (op["name"], p, v)
    table = runner.invoke(app, ["optimize", str(DEMO_PLAN)], env={"COLUMNS": "80"})
    assert "2.943  0.3248    200" in table.stdout


@pytest.fixture(scope="module")
def sqlite_server(tmp_path_factory):
    live = LiveServer(
        f"sqlite:///{tmp_path_factory.mktemp('db') / 'rcb.db'}",
        tmp_path_factory.mktemp("log") / "serve.log",
    )
    live.start()
    yield live
    live.stop()


def test_rest_setpoints_are_on_the_plans_grid_and_a_bad_step_is_a_problem(sqlite_server):
    import tomllib

    body = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
    body["machine"]["resolution"] = {"depth_mm": 0.01, "feed_mm_rev": 0.001}
    with sqlite_server.client("engineer") as c:
        created = c.post("/plans", json=body)
        assert created.status_code == 201, created.text
        plan_id = created.json()["id"]
        answer = c.get(f"/plans/{plan_id}/setpoints").json()
        rough = next(op for op in answer["operations"] if op["name"] == "rough-od")
        # continuous d 2.94371, f 0.324811: one depth step up and one feed step down meets
        # force (F ~ d^0.888 f^0.783: +0.19 % -0.20 %) and roughness, and removes more
        assert rough["setpoint"] == {"depth_mm": 2.95, "feed_mm_rev": 0.324, "speed_m_min": 200.0}
        for op in answer["operations"]:
            for p, v in op["setpoint"].items():
                assert on_grid(v, {**DEFAULT_RESOLUTION, **body["machine"]["resolution"]}[p])
        body["machine"]["resolution"] = {"speed_m_min": -1}
        bad = c.post("/plans", json=body)
    assert bad.status_code == 422
    assert bad.headers["content-type"].startswith("application/problem+json")
    assert "resolution" in bad.text and "speed_m_min" in bad.text
