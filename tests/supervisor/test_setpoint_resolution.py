"""Setpoints are machine values: within their bounds, on the machine's resolution grid, safe.

The rule (:mod:`supervisor.optimize.grid`): the best grid neighbour of the continuous optimum
that meets every robust row, else the best neighbour of the tightened program's optimum; the
predictions are those of the grid point. The grid is ``[machine.resolution]`` of the plan
(:mod:`supervisor.inputs.resolution`). Checked here on hand-made programs, on random plans
(Hypothesis), on the learn strategy's cone setpoints, milling and constant-load plans, the
virtual machine's oracle, the CLI and the REST service.
"""

from __future__ import annotations

import copy
import json
import math
from decimal import Decimal
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import assume, event, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from test_properties import Scenario, robust_edges, scenarios

from api.cli.main import app
from models import kinematics
from models.errors import InputError
from models.tool import predict_all
from supervisor.errors import InfeasibleError, PlanError
from supervisor.inputs.part_report import PartReport
from supervisor.inputs.plan import load_plan, plan_from_mapping
from supervisor.inputs.resolution import DEFAULT_RESOLUTION, steps_within
from supervisor.optimize import grid, highs_lp
from supervisor.optimize.formulation import formulate
from supervisor.optimize.optimizer import optimize_plan
from supervisor.optimize.program import LogLinearProgram, Row
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


def on_grid(value: float, step: float) -> bool:
    """``value`` is a whole number of ``step`` as written (decimal arithmetic)."""
    return Decimal(repr(value)) % Decimal(repr(step)) == 0


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


# --------------------------------------------------------------------------- the rule


def test_float_noise_next_to_a_bound_is_the_bound():
    # the values: 3.0000000000000004 with bound 3.0, 10.000000000000002 on a 10 mm
    # tool (radial depth fixed), 199.99999999999991 with bound 200
    bounds = {"depth_mm": (0.5, 3.0), "radial_depth_mm": (10.0, 10.0), "speed_m_min": (100, 200)}
    values = (3.0000000000000004, 10.000000000000002, 199.99999999999991)
    points = grid.candidates(tuple(bounds), values, bounds, DEFAULT_RESOLUTION)
    assert points.tolist() == [[3.0, 10.0, 200.0]]


def _program(rows, lower, upper, objective=(1.0, 1.0, 1.0)) -> LogLinearProgram:
    return LogLinearProgram(
        operation="op",
        parameters=("depth_mm", "feed_mm_rev", "speed_m_min"),
        objective=tuple(objective),
        rows=tuple(
            Row(f"q{i}", c, b, math.exp(b), "max", f"q{i}") for i, (c, b) in enumerate(rows)
        ),
        lower=tuple(math.log(v) for v in lower),
        upper=tuple(math.log(v) for v in upper),
    )


def _solve_or_none(lp: LogLinearProgram) -> np.ndarray | None:
    status, x = highs_lp.maximize(lp)
    return np.clip(x, lp.lower, lp.upper) if status == "optimal" else None


def test_rounding_the_speed_down_would_break_roughness_so_the_rule_does_not():
    # Roughness f · v^-0.5 <= R (it falls with speed) binds with v on its bound 200.5, which
    # is no grid point: v must go down to 200, and with it the feed by sqrt(200/200.5) - 1
    # = -0.125 %, more than one feed step (0.0001 of about 0.3 mm/rev). So no grid
    # neighbour of the optimum meets the row (rounding everything down breaks it); fixing v
    # first (its one candidate) and re-solving gives the feed.
    bounds = {"depth_mm": (0.5, 3.0), "feed_mm_rev": (0.05, 0.6), "speed_m_min": (100, 200.5)}
    rhs = math.log(0.3) - 0.5 * math.log(200.5)
    lp = _program([((0.0, 1.0, -0.5), rhs)], *zip(*bounds.values(), strict=True))
    x = _solve_or_none(lp)
    assert x is not None
    assert_allclose(np.exp(x), [3.0, 0.3, 200.5])
    floor = np.array([3.0, 0.2999, 200.0])  # every parameter rounded down
    assert not grid.meets(lp, floor[None, :])[0]
    assert grid.on_grid(lp, x, bounds, DEFAULT_RESOLUTION) is None
    found = grid.machine_point(lp, x, bounds, DEFAULT_RESOLUTION, _solve_or_none)
    assert found is not None
    # f <= 0.3 · sqrt(200 / 200.5) = 0.299626: the best grid feed at v = 200 is 0.2996
    assert found[2].tolist() == [3.0, 0.2996, 200.0]
    assert grid.meets(lp, found[2][None, :])[0]
    # the last resort alone (tightened rows) is safe too, at one step of v at its low bound
    tight = grid.tightened(lp, bounds, DEFAULT_RESOLUTION)
    x_tight = _solve_or_none(tight)
    point = grid.on_grid(lp, x_tight, bounds, DEFAULT_RESOLUTION)
    assert point is not None and grid.meets(lp, point[None, :])[0]
    assert point[1] < 0.2996


steps = st.fixed_dictionaries(
    {
        "depth_mm": st.sampled_from([0.1, 0.01, 0.001]),
        "feed_mm_rev": st.sampled_from([0.01, 0.001, 0.0001]),
        "speed_m_min": st.sampled_from([5.0, 1.0, 0.5, 0.1]),
    }
)
exponent = st.floats(-2.0, 2.0, allow_nan=False).map(lambda v: round(v, 3))


@settings(max_examples=200, deadline=None)
@given(
    rows=st.lists(st.tuples(st.tuples(exponent, exponent, exponent), st.floats(0.0, 0.5))),
    lower=st.tuples(st.floats(0.05, 3.0), st.floats(0.01, 0.5), st.floats(20.0, 300.0)),
    ratio=st.tuples(*[st.floats(1.0, 5.0)] * 3),
    where=st.tuples(*[st.floats(0.0, 1.0)] * 3),
    objective=st.tuples(*[st.sampled_from([0.0, 0.5, 1.0])] * 3),
    resolution=steps,
)
def test_the_rule_never_returns_a_point_that_breaks_a_row_or_a_bound(
    rows, lower, ratio, where, objective, resolution
):
    # rows through a point inside the bounds, 0-0.5 above it in ln: feasible, and they bind
    upper = tuple(lo * r for lo, r in zip(lower, ratio, strict=True))
    inside = [math.log(lo) + t * math.log(r) for lo, r, t in zip(lower, ratio, where, strict=True)]
    rows = [(a, float(np.dot(a, inside)) + m) for a, m in rows]
    for p, lo, hi in zip(("depth_mm", "feed_mm_rev", "speed_m_min"), lower, upper, strict=True):
        k_low, k_high = steps_within(lo, hi, resolution[p])
        assume(k_low <= k_high)  # a plan refuses bounds that hold no grid point
    pairs = zip(lower, upper, strict=True)
    bounds = dict(zip(("depth_mm", "feed_mm_rev", "speed_m_min"), pairs, strict=True))
    lp = _program(rows, lower, upper, objective)
    x = _solve_or_none(lp)
    if x is None:
        return
    found = grid.machine_point(lp, x, bounds, resolution, _solve_or_none)
    if found is None:
        event("no grid point proven safe")
        assert _solve_or_none(grid.tightened(lp, bounds, resolution)) is None
        return
    held, _, point = found
    if held is not lp:
        event("tightened program")
    elif grid.on_grid(lp, x, bounds, resolution) is None:
        event("fix and re-solve")
    else:
        event("a grid neighbour")
    for (p, (low, high)), v in zip(bounds.items(), point, strict=True):
        assert low <= v <= high
        assert on_grid(float(v), resolution[p])
    ln = np.log(point)
    for coefficients, rhs in rows:
        assert float(np.dot(coefficients, ln)) <= rhs + 1e-12


@settings(max_examples=150, deadline=None)
@given(
    rows=st.lists(
        st.tuples(st.tuples(exponent, exponent, exponent), st.floats(0.0, 0.5)), min_size=1
    ),
    lower=st.tuples(st.floats(0.05, 3.0), st.floats(0.01, 0.5), st.floats(20.0, 300.0)),
    ratio=st.tuples(*[st.floats(1.0, 5.0)] * 3),
    where=st.tuples(*[st.floats(0.0, 1.0)] * 3),
    objective=st.tuples(*[st.floats(0.1, 1.0)] * 3),
    resolution=steps,
)
def test_every_grid_neighbour_of_the_tightened_optimum_meets_every_row(
    rows, lower, ratio, where, objective, resolution
):
    # the last resort's guarantee, by construction: rows tightened by one step of every
    # parameter at its low bound (ln(1 + step/low)) leave room for any rounding. The rows
    # pass a point inside the bounds with a margin of 0-0.5 in ln, so that they bind.
    upper = tuple(lo * r for lo, r in zip(lower, ratio, strict=True))
    params = ("depth_mm", "feed_mm_rev", "speed_m_min")
    for p, lo, hi in zip(params, lower, upper, strict=True):
        k_low, k_high = steps_within(lo, hi, resolution[p])
        assume(k_low <= k_high)
    bounds = dict(zip(params, zip(lower, upper, strict=True), strict=True))
    inside = [math.log(lo) + t * math.log(r) for lo, r, t in zip(lower, ratio, where, strict=True)]
    through = [(a, float(np.dot(a, inside)) + m) for a, m in rows]
    lp = _program(through, lower, upper, objective)
    x = _solve_or_none(grid.tightened(lp, bounds, resolution))
    if x is None:
        event("the tightened program is infeasible")
        return
    points = grid.candidates(params, np.exp(x), bounds, resolution)
    event(f"{len(points)} neighbours")
    assert grid.meets(lp, points).all()


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
