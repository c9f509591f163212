"""The robust optimiser against Ivester & Heigel Table 5 and hand-solved cases."""

from __future__ import annotations

import json
import math
import tomllib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace

import pytest
from numpy.testing import assert_allclose

from api.cli.main import app
from models.catalogue import get_tool
from models.errors import InputError
from supervisor.errors import InfeasibleError
from supervisor.inputs.plan import load_plan, plan_from_mapping
from supervisor.optimize.optimizer import optimize_operation, optimize_plan

from conftest import DEMO_PLAN, FINE, step1_plan

STEP1 = step1_plan(FINE)


def _solve(data):
    return optimize_plan(plan_from_mapping(data)).operations[0]


def test_step1_row_r():
    # Ivester & Heigel Table 5 step 1 row R: d 3.0, f 0.32, v 200, 190.72 cm³/min, with
    # force <= 2000 N and Ra <= 4.0 µm at the band edge. Exact optimum: d 2.944, f 0.3248.
    op = _solve(STEP1)
    assert_allclose(op.mrr_cm3_min, 191.2, rtol=0.005)
    assert 2.94 <= op.setpoint["depth_mm"] <= 3.0
    assert 0.32 <= op.setpoint["feed_mm_rev"] <= 0.325
    assert_allclose(op.setpoint["speed_m_min"], 200.0)
    assert {"force_N", "roughness_um"} <= set(op.binding)
    assert "power_kW" not in op.binding
    assert_allclose(op.predicted["force_N"].upper, 2000.0, rtol=1e-6)
    assert_allclose(op.predicted["roughness_um"].upper, 4.0, rtol=1e-6)
    assert_allclose(op.time_min, 86400 / 1000 / op.mrr_cm3_min)


def test_5kW_machine_makes_power_bind():
    data = json.loads(json.dumps(STEP1))
    data["machine"]["max_power_kW"] = 5
    op = _solve(data)
    assert "power_kW" in op.binding and "force_N" not in op.binding
    assert_allclose(op.predicted["power_kW"].upper, 5.0, rtol=1e-6)
    assert op.mrr_cm3_min < 191.2


def test_torque_rpm_and_feed_rate_limits_bind():
    data = json.loads(json.dumps(STEP1))
    data["machine"] = {
        "name": "small",
        "max_spindle_rpm": 800,
        "max_torque_Nm": 40,
        "resolution": FINE,
    }
    op = _solve(data)
    # 800 rpm on Ø60 mm caps v at 800·π·60/1000 = 150.80 m/min
    assert_allclose(op.setpoint["speed_m_min"], 800 * math.pi * 60 / 1000, rtol=1e-6)
    assert {"spindle_rpm", "torque_Nm"} <= set(op.binding)
    assert_allclose(op.predicted["torque_Nm"].upper, 40.0, rtol=1e-6)


def test_a_solve_does_not_depend_on_what_was_solved_before():
    plan = load_plan(DEMO_PLAN)
    first = optimize_plan(plan)
    for op in reversed(plan.operations):  # other programs in between, in another order
        optimize_operation(op, plan.tools[op.tool], plan.machine)
    assert optimize_plan(plan) == first
    with ThreadPoolExecutor(max_workers=2) as pool:  # a thread has its own HiGHS instance
        assert list(pool.map(lambda _: optimize_plan(plan), range(4))) == [first] * 4


def test_a_narrower_force_band_lets_the_cut_go_faster():
    plan = load_plan(DEMO_PLAN)
    plan = replace(plan, machine=replace(plan.machine, resolution=FINE))
    op = plan.operations[0]
    tool = plan.tools[op.tool]
    narrower = replace(tool.models["force_N"], dK=100.0)
    tool2 = replace(tool, models={**tool.models, "force_N": narrower})
    slow = optimize_operation(op, tool, plan.machine)
    fast = optimize_operation(op, tool2, plan.machine)
    # dK 150 N: the force band's upper edge sits on the plan's 2000 N limit (Table 5 step 1 R)
    assert "force_N" in slow.binding
    assert_allclose(slow.predicted["force_N"].upper, 2000.0, rtol=1e-6)
    # dK 100 N: the depth reaches its 3.0 mm bound before the force limit
    assert fast.binding == ("roughness_um", "depth_mm", "speed_m_min")
    assert fast.mrr_cm3_min > slow.mrr_cm3_min
    assert fast.predicted["force_N"].upper < 2000.0


# Ivester & Heigel Table 5 rows R: (d, f, v); the paper rounds feeds down to 0.01 mm/rev.
TABLE5_R = {
    "rough-od": (3.0, 0.32, 200),
    "rough-grooves": (3.0, 0.10, 200),
    "rough-contour": (3.0, 0.14, 130),
    "finish-grooves": (2.0, 0.05, 190),
    "finish-contour": (2.0, 0.05, 110),
}


def test_demo_part_reproduces_table5_rows_r(runner):
    result = runner.invoke(app, ["optimize", str(DEMO_PLAN), "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    ops = {op["name"]: op for op in data["operations"]}
    assert list(ops) == [
        "rough-od",
        "rough-grooves",
        "rough-contour",
        "finish-od",
        "finish-grooves",
        "finish-contour",
    ]
    for name, (d, f, v) in TABLE5_R.items():
        s = ops[name]["setpoint"]
        assert_allclose(s["depth_mm"], d, rtol=0.02), name
        assert math.floor(s["feed_mm_rev"] * 100) / 100 == f, name
        assert_allclose(s["speed_m_min"], v), name
        assert "roughness_um" in ops[name]["binding"], name
    # Step 4's model rows in Table 5 are inconsistent (seeds README); the model at the
    # Table 4 limit of 2.5 µm and d <= 1 mm, v <= 190 gives f = 0.1138 mm/rev.
    assert_allclose(ops["finish-od"]["setpoint"]["feed_mm_rev"], 0.1138, rtol=2e-3)
    total = sum(op["time_min"] for op in data["operations"])
    assert_allclose(data["cycle_time_min"], total)
    for op in data["operations"]:
        assert set(op) >= {"name", "setpoint", "predicted", "mrr_cm3_min", "time_min", "binding"}


def test_tool_life_binds_when_more_parts_per_edge_are_asked():
    data = json.loads(json.dumps(STEP1))
    op_data = data["operations"][0]
    op_data["limits"]["parts_per_edge"] = 40
    op_data["allowable_flank_wear_mm"] = 0.3
    op = _solve(data)
    assert "tool_life_mm3" in op.binding
    # lower band edge of Eq. 8 covers 40 parts of 86400 mm³
    assert_allclose(op.predicted["tool_life_mm3"].lower, 40 * 86400, rtol=1e-6)
    assert op.mrr_cm3_min < 191.2


def test_setpoint_uncertainty_widens_the_band_and_slows_the_cut():
    data = json.loads(json.dumps(STEP1))
    data["operations"][0]["setpoint_rel_uncertainty"] = {"feed_mm_rev": 0.05}
    op = _solve(data)
    f = op.predicted["force_N"]
    # GUM: ΔF/F = sqrt((150/2130)² + (0.783·0.05)²) = 0.08059
    assert_allclose(f.band / f.value, math.hypot(150 / 2130, 0.783 * 0.05))
    assert op.mrr_cm3_min < 191.2


def test_milling_operation_hand_solved():
    # Force 1100·ap·ae·fz^0.75 at the band edge (K 1000, ΔK 100) <= 500 N; spindle <= 8000 rpm
    # on a Ø10 mm cutter caps vc at 251.33 m/min. fz goes to its bound 0.2 (force grows slower
    # in fz than MRR), then ap·ae = 500/(1100·0.2^0.75) = 1.5199 mm², so
    # MRR = 1.5199 · 0.2 · 4 · 8000 / 1000 = 9.727 cm³/min.
    data = {
        "name": "mill",
        "machine": {
            "name": "vmc",
            "max_spindle_rpm": 8000,
            "max_feed_rate_mm_min": 10000,
            "resolution": FINE,
        },
        "tools": [
            {
                "name": "EM10",
                "process": "milling",
                "models": {
                    "force_N": {
                        "K": 1000,
                        "dK": 100,
                        "exponents": {
                            "axial_depth_mm": 1,
                            "radial_depth_mm": 1,
                            "feed_per_tooth_mm": 0.75,
                        },
                    }
                },
            }
        ],
        "operations": [
            {
                "name": "pocket",
                "tool": "EM10",
                "tool_diameter_mm": 10,
                "flute_count": 4,
                "volume_mm3": 20000,
                "limits": {"force_N": 500},
                "bounds": {
                    "axial_depth_mm": [0.5, 2],
                    "radial_depth_mm": [1, 5],
                    "feed_per_tooth_mm": [0.02, 0.2],
                    "speed_m_min": [50, 400],
                },
            }
        ],
    }
    op = _solve(data)
    assert_allclose(op.mrr_cm3_min, 500 / (1100 * 0.2**0.75) * 0.2 * 4 * 8000 / 1000, rtol=1e-6)
    assert_allclose(op.mrr_cm3_min, 9.727, rtol=1e-3)
    assert {"force_N", "spindle_rpm", "feed_per_tooth_mm"} <= set(op.binding)
    assert_allclose(op.predicted["feed_rate_mm_min"].value, 6400, rtol=1e-6)


def test_plan_file_and_catalogue_give_the_same_model():
    plan = load_plan(DEMO_PLAN)
    assert plan.tools["CNMG432RN"] == get_tool("CNMG432RN")
    raw = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
    assert len(raw["operations"]) == len(plan.operations) == 6


def test_no_limit_goes_to_the_upper_bounds():
    data = json.loads(json.dumps(STEP1))
    data["machine"] = {"name": "unlimited"}
    data["operations"][0]["limits"] = {}
    op = _solve(data)
    assert op.setpoint == pytest.approx({"depth_mm": 3.0, "feed_mm_rev": 0.6, "speed_m_min": 200})
    assert set(op.binding) == {"depth_mm", "feed_mm_rev", "speed_m_min"}


def test_table_output_shows_the_json_numbers(runner):
    # The rich table (80 columns when piped) carries the same setpoints as --json.
    table = runner.invoke(app, ["optimize", str(DEMO_PLAN)], env={"COLUMNS": "80"})
    assert table.exit_code == 0, table.output
    for line in table.stdout.splitlines():
        assert len(line) <= 80, line
    data = json.loads(runner.invoke(app, ["optimize", str(DEMO_PLAN), "--json"]).stdout)
    rough = data["operations"][0]
    row = next(line for line in table.stdout.splitlines() if "rough-od " in line)
    for value in (rough["setpoint"]["depth_mm"], rough["setpoint"]["feed_mm_rev"]):
        assert f"{value:.4g}" in row  # 2.944, 0.3248 (Table 5 step 1 row R: 3.0, 0.32)
    assert f"{rough['mrr_cm3_min']:.4g}" in row  # 191.2
    assert f"cycle time {data['cycle_time_min']:.4g} min" in table.stdout


def test_absurdly_small_machine_limits_are_diagnosed_not_overflowed():
    # found by schemathesis: max_spindle_rpm = 5e-324 made the diagnosis's exp(slack) overflow.
    # A plan file or a REST body now refuses it (models.bounds.SMALLEST_POSITIVE, issue 29):
    # the optimizer is given the machine directly, and must still diagnose, not overflow.
    body = {
        "name": "tiny",
        "machine": {"name": "m", "max_spindle_rpm": 5e-324, "max_torque_Nm": 5e-324},
        "operations": [
            {
                "name": "rough-od",
                "tool": "CNMG432RN",
                "workpiece_diameter_mm": 60,
                "volume_mm3": 86400,
                "bounds": {
                    "depth_mm": [0.5, 3],
                    "feed_mm_rev": [0.1, 0.6],
                    "speed_m_min": [100, 200],
                },
            }
        ],
    }
    with pytest.raises(InputError) as refused:
        plan_from_mapping(body)
    assert refused.value.field in ("machine.max_spindle_rpm", "machine.max_torque_Nm")
    machine = {**body["machine"], "max_spindle_rpm": 1.0, "max_torque_Nm": 1.0}
    plan = plan_from_mapping({**body, "machine": machine})
    tiny = replace(plan.machine, limit_of={"spindle_rpm": 5e-324, "torque_Nm": 5e-324})
    with pytest.raises(InfeasibleError) as err:
        optimize_plan(replace(plan, machine=tiny))
    needed = {c.name: c.required for c in err.value.conflicts}
    # at the lower bounds (v = 100 m/min on Ø60): n = 1000·v/(π·D) = 530.5 rpm
    assert needed["machine.max_spindle_rpm"] == pytest.approx(1000 * 100 / (math.pi * 60), rel=1e-6)
