"""Whole passes (issue 19 item 9): stock_mm cut in the count of passes that takes least time.

The chosen count equals a brute force over every count (Hypothesis, turning and milling, with
and without a finishing pass); its time lies between the continuous optimum and the continuous
optimum rounded up to whole passes; golden counts and times of the two example plans worked by
hand from their models; plan errors name the field. RCB, storage and the CLI:
``test_passes_rcb.py``.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from models.errors import InputError
from supervisor.errors import InfeasibleError
from supervisor.inputs.passes import DEPTH, MAX_PASSES, pass_spec
from supervisor.inputs.plan import load_plan, plan_from_mapping
from supervisor.optimize.optimizer import optimize_operation, optimize_plan
from supervisor.optimize.passes import TIE_RTOL, group_time_min, roughing_pass

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
TURNING = EXAMPLES / "turning_passes_part.toml"
MILLING = EXAMPLES / "milling_passes_part.toml"
RPM = 1000 / math.pi  # n = 1000 v / (π D)


# ---------------------------------------------------------------------------- random plans


def _plan(process, force, rough, limits, bounds, stock, finish, context):
    op = {
        "name": "op",
        "tool": "T",
        "volume_mm3": 20000.0,
        "stock_mm": stock,
        "limits": limits,
        "bounds": bounds,
        **context,
    }
    if finish is not None:
        op["finish"] = finish
    return {
        "name": "random",
        "machine": {"name": "m", "max_power_kW": 30, "max_spindle_rpm": 6000},
        "tools": [
            {
                "name": "T",
                "process": process,
                "models": {"force_N": force, "roughness_um": rough},
            }
        ],
        "operations": [op],
    }


@st.composite
def turning_plans(draw):
    u = lambda lo, hi: draw(st.floats(lo, hi))  # noqa: E731
    force = {
        "K": u(500, 3000),
        "dK": 0.0,
        "exponents": {
            "depth_mm": u(0.5, 1.2),
            "feed_mm_rev": u(0.4, 1.0),
            "speed_m_min": u(-0.3, 0.1),
        },
    }
    force["dK"] = force["K"] * u(0.02, 0.3)
    rough = {
        "K": u(10, 60),
        "dK": 0.0,
        "exponents": {"depth_mm": u(0, 0.2), "feed_mm_rev": u(0.8, 1.5), "speed_m_min": u(-0.3, 0)},
    }
    rough["dK"] = rough["K"] * u(0.02, 0.3)
    stock = u(0.5, 6)
    finish = None
    if draw(st.booleans()) and stock > 0.5:
        finish = {"depth_mm": u(0.1, min(0.6, stock - 0.3)), "limits": {"roughness_um": u(0.8, 3)}}
    limits = {"force_N": u(300, 3000), "roughness_um": u(1, 6)}
    bounds = {
        "depth_mm": [0.2, u(0.5, 4)],
        "feed_mm_rev": [0.05, u(0.2, 0.8)],
        "speed_m_min": [80, u(120, 300)],
    }
    context = {"workpiece_diameter_mm": u(20, 100)}
    return _plan("turning", force, rough, limits, bounds, stock, finish, context)


@st.composite
def milling_plans(draw):
    u = lambda lo, hi: draw(st.floats(lo, hi))  # noqa: E731
    exponents = {
        "axial_depth_mm": u(0.5, 1.2),
        "radial_depth_mm": u(0.5, 1.5),
        "feed_per_tooth_mm": u(0.4, 1.0),
        "speed_m_min": u(-0.3, 0.1),
    }
    force = {"K": u(10, 60), "dK": 0.0, "exponents": exponents}
    force["dK"] = force["K"] * u(0.02, 0.3)
    rough_exp = {"feed_per_tooth_mm": u(0.5, 1.2), "speed_m_min": u(-0.3, 0)}
    rough = {"K": u(20, 80), "dK": 0.0, "exponents": rough_exp}
    rough["dK"] = rough["K"] * u(0.02, 0.3)
    stock = u(1, 8)
    finish = None
    if draw(st.booleans()):
        finish = {"axial_depth_mm": u(0.1, 0.6), "limits": {"roughness_um": u(0.8, 3)}}
    limits = {"force_N": u(100, 600), "roughness_um": u(1.5, 6)}
    bounds = {
        "axial_depth_mm": [0.3, u(1, 5)],
        "radial_depth_mm": [1, u(2, 10)],
        "feed_per_tooth_mm": [0.01, u(0.03, 0.1)],
        "speed_m_min": [80, u(100, 300)],
    }
    context = {"tool_diameter_mm": 10, "flute_count": 2}
    return _plan("milling", force, rough, limits, bounds, stock, finish, context)


def _brute_force(op, tool, machine):
    """(time, count) of the equal passes: every count whose depth is within the bounds."""
    spec = op.passes
    stock = spec.roughing_stock_mm
    lo, hi = op.bounds[DEPTH[op.process]]
    best = None
    for n in range(1, MAX_PASSES + 1):
        d = stock / n
        if d > hi * (1 + 1e-9):
            continue
        if d < lo * (1 - 1e-9):
            break
        try:
            result = optimize_operation(roughing_pass(op, n), tool, machine)
        except InfeasibleError:
            continue
        time = group_time_min(op, n, d, result.mrr_cm3_min)
        if best is None or time < best[0] * (1 - TIE_RTOL):
            best = (time, n)
    return best


def _check_against_brute_force(body):
    try:
        plan = plan_from_mapping(body)
    except InputError as err:  # no whole count of passes fits the depth bounds: refused
        assert err.field == "operations[0].stock_mm"
        assume(False)
    op, tool, machine = plan.operations[0], plan.tools["T"], plan.machine
    brute = _brute_force(op, tool, machine)
    try:
        result = optimize_operation(op, tool, machine)
    except InfeasibleError:
        if op.passes.finish is None:  # the finish alone may be what cannot be met
            assert brute is None
        assume(False)
    assert brute is not None
    rough = result.passes.groups[0]
    assert rough.count == brute[1]
    assert rough.result.time_min == pytest.approx(brute[0], rel=1e-12)
    groups = result.passes.groups
    assert result.passes.count == sum(g.count for g in groups)
    assert sum(g.count * g.depth_mm for g in groups) == pytest.approx(op.passes.stock_mm)
    assert result.time_min == pytest.approx(sum(g.result.time_min for g in groups))
    # between the continuous optimum and the continuous optimum rounded up to whole passes
    stock = op.passes.roughing_stock_mm
    volume = op.volume_mm3 * stock / op.passes.stock_mm
    depth = DEPTH[op.process]
    # never faster than the continuous optimum (off the machine's grid: a fine resolution)
    fine = replace(machine, resolution=dict.fromkeys(machine.resolution, 1e-09))
    exact = optimize_operation(replace(op, passes=None), tool, fine)
    t_cont = volume / (1000 * exact.mrr_cm3_min)
    assert rough.result.time_min >= t_cont * (1 - 1e-6)
    # never slower than the grid's optimum rounded up to whole passes: its feed and speed,
    # on the grid, still hold at the shallower depth (every maximum rises with depth)
    cont = optimize_operation(replace(op, passes=None), tool, machine)
    d_star = cont.setpoint[depth]
    rate_per_mm = cont.mrr_cm3_min / d_star  # R = MRR / d at the continuous optimum
    n_up = max(1, math.ceil(stock / d_star * (1 - 1e-9)))
    if stock / n_up >= op.bounds[depth][0]:  # the rounded-up depth is within the bounds
        t_up = volume * n_up / (1000 * stock * rate_per_mm)
        assert rough.result.time_min <= t_up * (1 + 1e-6)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(turning_plans())
def test_turning_count_is_the_brute_force_one_and_beats_the_rounded_continuous_optimum(body):
    _check_against_brute_force(body)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(milling_plans())
def test_milling_count_is_the_brute_force_one_and_beats_the_rounded_continuous_optimum(body):
    _check_against_brute_force(body)


# ---------------------------------------------------------------------------- golden values


def test_milling_slot_takes_three_passes_of_2_mm_worked_by_hand():
    # examples/milling_passes_part.toml: F = (26.61 + 6.65)·ap·ae^1.432·fz^0.695 <= 230 N,
    # fz in [0.018, 0.047] mm, v <= 145 m/min, ae = 10 mm, z = 2, D = 10 mm, V = 6000 mm³
    result = {op.name: op for op in optimize_plan(load_plan(MILLING)).operations}["slot"]
    rpm = RPM * 145 / 10

    def time_min(n):
        ap = 6 / n
        fz = min(0.047, (230 / (33.26 * ap * 10**1.432)) ** (1 / 0.695))
        return 6000 / (ap * 10 * fz * 2 * rpm)  # V / (1000 · MRR[cm³/min]) = V / (ap ae vf)

    # one pass would be 6 mm > 4 mm; two: force-bound fz = 0.02893 mm; three and four: fz bound
    assert [time_min(n) for n in (2, 3, 4)] == pytest.approx([0.7488, 0.6915, 0.9220], rel=1e-3)
    assert result.passes.count == 3
    (rough,) = result.passes.groups
    assert rough.depth_mm == pytest.approx(2.0)
    assert rough.result.setpoint["feed_per_tooth_mm"] == pytest.approx(0.047)
    assert result.time_min == pytest.approx(time_min(3), rel=1e-6)
    assert result.mrr_cm3_min == pytest.approx(6000 / 1000 / time_min(3), rel=1e-6)


def test_turning_od_takes_two_roughing_passes_and_a_finish_worked_by_hand():
    # examples/turning_passes_part.toml, CNMG432RN (Ivester & Heigel Tables 2-3):
    # Ra = (54 + 14)·d^-0.006·f^1.284·v^-0.261 <= 4.0 µm roughing, 1.6 µm finishing (v = 200)
    result = {op.name: op for op in optimize_plan(load_plan(TURNING)).operations}
    od = result["od-passes"]
    assert od.passes.count == 3
    rough, finish = od.passes.groups
    assert (rough.kind, rough.count, finish.kind, finish.count) == ("roughing", 2, "finishing", 1)
    assert rough.depth_mm == pytest.approx(2.25) and finish.depth_mm == pytest.approx(0.5)

    def feed(limit, d):
        # the continuous optimum, floored to the plan's 0.0001 mm/rev grid (roughness rises
        # with feed: down is the safe side; supervisor.optimize.grid)
        exact = (limit / (68 * d**-0.006 * 200**-0.261)) ** (1 / 1.284)
        return math.floor(exact * 1e4) / 1e4

    assert rough.result.setpoint["feed_mm_rev"] == pytest.approx(feed(4.0, 2.25), rel=1e-9)
    assert finish.result.setpoint["feed_mm_rev"] == pytest.approx(feed(1.6, 0.5), rel=1e-9)
    # V·c·d/S over d·f·v: 95033 mm³ of a 5 mm stock
    t_rough = 95033 * 4.5 / 5 / (1000 * 2.25 * feed(4.0, 2.25) * 200)
    t_finish = 95033 * 0.5 / 5 / (1000 * 0.5 * feed(1.6, 0.5) * 200)
    assert od.time_min == pytest.approx(t_rough + t_finish, rel=1e-6)
    assert od.setpoint == rough.result.setpoint  # the operation's setpoint: the roughing one
    assert "depth_mm" not in finish.result.binding  # fixed by the plan, not a bound
    face = result["face"]
    assert face.passes.count == 1 and face.setpoint["depth_mm"] == pytest.approx(3.0)


# ---------------------------------------------------------------------------- plan errors


def _body(**changes):
    body = tomllib.loads(TURNING.read_text(encoding="utf-8"))
    body["operations"][0].update(changes)
    return body


@pytest.mark.parametrize(
    ("changes", "field", "words"),
    [
        (
            {
                "stock_mm": 5.0,
                "bounds": {
                    "depth_mm": [2.6, 2.9],
                    "feed_mm_rev": [0.1, 0.6],
                    "speed_m_min": [100, 200],
                },
            },
            "operations[0].stock_mm",
            "no whole number of passes",
        ),
        ({"stock_mm": 5000.0, "finish": {"depth_mm": 0.5}}, "operations[0].stock_mm", "1000"),
        ({"stock_mm": -1}, "operations[0].stock_mm", ""),
        ({"finish": {"depth_mm": 6}}, "operations[0].finish.depth_mm", "less than stock_mm"),
        ({"finish": {"depth_mm": 0.5, "speed": 1}}, "operations[0].finish", ""),
        ({"finish": {"limits": {}}}, "operations[0].finish.depth_mm", "required"),
        (
            {"finish": {"depth_mm": 0.5, "limits": {"tool_life": 1}}},
            "operations[0].finish.limits",
            "",
        ),
    ],
)
def test_bad_passes_are_refused_naming_the_field(changes, field, words):
    with pytest.raises(InputError) as err:
        plan_from_mapping(_body(**changes))
    assert err.value.field.startswith(field)
    assert words in str(err.value)


def test_passes_minimise_time_so_the_productivity_objective_is_refused():
    table = {"stock_mm": 2.0, "objective": "productivity"}
    with pytest.raises(InputError) as err:
        pass_spec(table, "operations[0]", "milling", {}, lambda d, p: {}, ())
    assert err.value.field == "operations[0].stock_mm" and "objective" in str(err.value)


def test_a_finish_limit_on_power_needs_the_force_model():
    table = {"stock_mm": 2.0, "finish": {"axial_depth_mm": 0.5, "limits": {"power_kW": 1}}}
    with pytest.raises(InputError) as err:
        pass_spec(table, "operations[0]", "milling", {}, lambda d, p: dict(d), ("roughness_um",))
    assert err.value.field == "operations[0].finish.limits.power_kW"


def test_finish_without_stock_is_refused_and_depth_bound_is_optional():
    body = _body()
    del body["operations"][0]["stock_mm"]
    with pytest.raises(InputError) as err:
        plan_from_mapping(body)
    assert err.value.field == "operations[0].finish"
    face = load_plan(TURNING).operations[1]  # no depth bound given: stock / 1000 .. stock
    assert face.bounds["depth_mm"] == pytest.approx((3.0 / MAX_PASSES, 3.0))


def test_a_finish_that_cannot_be_met_names_the_finishing_pass():
    body = _body(finish={"depth_mm": 0.5, "limits": {"roughness_um": 0.05}})
    with pytest.raises(InfeasibleError) as err:
        optimize_plan(plan_from_mapping(body))
    assert "the finishing pass at depth_mm = 0.5" in str(err.value)
    assert err.value.conflicts[0].name == "roughness_um"
