"""The virtual machine: true processes inside the bands, measurement noise, wear, violations."""

from __future__ import annotations

import copy
import itertools
import math
import statistics
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from models.errors import InputError
from models.tool import predict_all
from supervisor.inputs.plan import load_plan, plan_from_mapping
from supervisor.optimize.optimizer import optimize_plan
from supervisor.virtual.machine import (
    DEFAULT_UNCERTAINTY,
    TABLE5_MEASURED_FINISH_PM_UM,
    TABLE5_MEASURED_FORCE_PM_N,
    Violation,
    VirtualMachine,
)
from supervisor.virtual.sampling import oracle_tools, sample_machine
from supervisor.virtual.simulate import measure_tool_wear, run_part

from conftest import DEMO_PLAN

PLAN = load_plan(DEMO_PLAN)
OPS = {op.name: op for op in PLAN.operations}
#: Solver tolerance of an optimum's removal rate (supervisor.optimize.solve.RECHECK_RTOL).
SOLVER_RTOL = 1e-6

ROUGH_OD = {
    "name": "one-op",
    "machine": {"name": "lathe", "max_power_kW": 22, "max_spindle_rpm": 4000},
    "operations": [
        {
            "name": "rough-od",
            "tool": "CNMG432RN",
            "workpiece_diameter_mm": 60,
            "volume_mm3": 86400,
            "limits": {"force_N": 2000, "roughness_um": 4.0, "parts_per_edge": 10},
            "bounds": {
                "depth_mm": [0.5, 3.0],
                "feed_mm_rev": [0.1, 0.6],
                "speed_m_min": [100, 200],
            },
        }
    ],
}


@pytest.fixture(scope="module")
def robust():
    return optimize_plan(PLAN)


def _setpoints(result):
    return {op.name: dict(op.setpoint) for op in result.operations}


def _point(op_name, setpoint):
    return {**setpoint, **OPS[op_name].context}


def _corners(op, names):
    """Every corner of the operation's bounds box in the variables ``names``."""
    axes = [op.bounds[n] if n in op.bounds else (op.context[n],) for n in names]
    for values in itertools.product(*axes):
        yield dict(zip(names, values, strict=True))


def _assert_inside_bands(plan, machine):
    for op in plan.operations:
        nominal = plan.tools[op.tool]
        true_tool = machine.processes[op.name].tool
        assert set(true_tool.models) == set(nominal.models)
        for quantity, model in nominal.models.items():
            true = true_tool.models[quantity]
            assert true.dK == 0
            assert true.K > 0
            assert set(true.exponents) == set(model.exponents)
            for corner in _corners(op, sorted(model.exponents)):
                y = model.monomial.evaluate(corner)
                y_true = true.monomial.evaluate(corner)
                assert abs(y_true - y) <= model.dK / model.K * y * (1 + 1e-9), (
                    op.name,
                    quantity,
                    corner,
                )


# ---------------------------------------------------------------------------- true processes


def test_same_seed_same_machine_and_outcomes(robust):
    a, b = sample_machine(PLAN, 11), sample_machine(PLAN, 11)
    assert a == b
    sp = _setpoints(robust)
    out_a = run_part(a, sp, np.random.default_rng(5), {"rough-od": 3})
    out_b = run_part(b, sp, np.random.default_rng(5), {"rough-od": 3})
    assert out_a == out_b


def test_different_seeds_differ():
    machines = [sample_machine(PLAN, seed) for seed in range(5)]
    ks = {
        tuple(m.processes[op.name].tool.models["force_N"].K for op in PLAN.operations)
        for m in machines
    }
    assert len(ks) == 5
    assert machines[0] != machines[1]


def test_measurement_stream_depends_on_rng(robust):
    m, sp = sample_machine(PLAN, 1), _setpoints(robust)
    a = run_part(m, sp, np.random.default_rng(1))
    b = run_part(m, sp, np.random.default_rng(2))
    assert a.true_values == b.true_values
    assert a.measurements != b.measurements


def test_truth_moves_within_band_not_beyond():
    # the spread is a third of the band: over 60 seeds K must move, and some by > 1/3 band
    ratios = [
        sample_machine(PLAN, seed).processes["rough-od"].tool.models["force_N"].K / 2130
        for seed in range(60)
    ]
    band = 150 / 2130  # CNMG432RN force, Ivester & Heigel Table 2
    assert max(abs(r - 1) for r in ratios) > band / 3
    assert statistics.pstdev(ratios) < band / 2


@pytest.mark.parametrize(
    ("spread", "exponent_spread"), [(1 / 3, 0.05), (3.0, 0.5), (0.0, 0.0), (1.0, 2.0)]
)
def test_true_models_stay_inside_band_at_every_corner(spread, exponent_spread):
    # wide spreads force the truncation of δ and the shrinking of ε
    for seed in range(40):
        machine = sample_machine(PLAN, seed, spread=spread, exponent_spread=exponent_spread)
        _assert_inside_bands(PLAN, machine)


def test_band_wider_than_k_keeps_k_positive():
    data = copy.deepcopy(ROUGH_OD)
    data["tools"] = [
        {
            "name": "LOOSE",
            "process": "turning",
            "models": {
                "force_N": {
                    "K": 2000,
                    "dK": 3000,
                    "exponents": {"depth_mm": 0.9, "feed_mm_rev": 0.8, "speed_m_min": -0.1},
                }
            },
        }
    ]
    op = data["operations"][0]
    op["tool"], op["limits"] = "LOOSE", {"force_N": 2000}
    plan = plan_from_mapping(data)
    for seed in range(40):
        machine = sample_machine(plan, seed, spread=2.0, exponent_spread=1.0)
        _assert_inside_bands(plan, machine)


def test_exact_models_stay_exact():
    data = copy.deepcopy(ROUGH_OD)
    exponents = {"depth_mm": 0.9, "feed_mm_rev": 0.8, "speed_m_min": -0.1}
    data["tools"] = [
        {
            "name": "EXACT",
            "process": "turning",
            "models": {"force_N": {"K": 2000, "dK": 0, "exponents": exponents}},
        }
    ]
    op = data["operations"][0]
    op["tool"], op["limits"] = "EXACT", {"force_N": 2000}
    plan = plan_from_mapping(data)
    true = sample_machine(plan, 3).processes["rough-od"].tool.models["force_N"]
    assert true.K == 2000
    assert dict(true.exponents) == exponents


def test_sample_refuses_negative_spread():
    with pytest.raises(InputError, match="spread"):
        sample_machine(PLAN, 0, spread=-0.1)


# ---------------------------------------------------------------------------- measurements


def test_default_uncertainties_are_table5_medians():
    # Ivester & Heigel Table 5, "Measured" ± columns: force median 3 N (the 80 N of step 4
    # row AC1 left out; with it the median is 3 N as well), finish median 0.05 µm
    assert len(TABLE5_MEASURED_FORCE_PM_N) == 18
    assert len(TABLE5_MEASURED_FINISH_PM_UM) == 19
    assert statistics.median([*TABLE5_MEASURED_FORCE_PM_N, 80]) == 3
    assert DEFAULT_UNCERTAINTY["force_N"] == 3.0
    assert DEFAULT_UNCERTAINTY["roughness_um"] == pytest.approx(0.05)
    machine = sample_machine(PLAN, 0, uncertainty={"force_N": 7.0})
    assert machine.uncertainty["force_N"] == 7.0
    assert machine.uncertainty["roughness_um"] == DEFAULT_UNCERTAINTY["roughness_um"]


def test_noise_free_measurement_is_the_true_model(robust):
    zero = {"force_N": 0.0, "roughness_um": 0.0}
    machine = sample_machine(PLAN, 4, uncertainty=zero)
    sp = _setpoints(robust)
    out = run_part(machine, sp, np.random.default_rng(0))
    for name, setpoint in sp.items():
        expected = predict_all(machine.processes[name].tool, _point(name, setpoint))
        assert set(out.true_values[name]) == set(expected)
        for quantity, prediction in expected.items():
            assert_allclose(out.true_values[name][quantity], prediction.value, rtol=1e-12)
        # measured: the "max" model quantities only, not tool life nor machine quantities
        assert set(out.measurements[name]) == {"force_N", "roughness_um"}
        for quantity, measured in out.measurements[name].items():
            assert_allclose(measured.value, expected[quantity].value, rtol=1e-12)
            assert measured.uncertainty == 0.0


def test_noise_has_half_the_expanded_uncertainty(robust):
    machine = sample_machine(PLAN, 2, uncertainty={"force_N": 10.0, "roughness_um": 0.2})
    sp = _setpoints(robust)
    rng = np.random.default_rng(123)
    outcomes = [run_part(machine, sp, rng) for _ in range(2000)]
    for name in sp:
        true = outcomes[0].true_values[name]
        for quantity, u in (("force_N", 10.0), ("roughness_um", 0.2)):
            values = np.array([o.measurements[name][quantity].value for o in outcomes])
            assert outcomes[0].measurements[name][quantity].uncertainty == u
            assert_allclose(values.std(ddof=1), u / 2, rtol=0.10)
            assert abs(values.mean() - true[quantity]) < 4 * (u / 2) / math.sqrt(2000)


def test_noisy_measurement_is_clipped_at_zero(robust):
    machine = sample_machine(PLAN, 2, uncertainty={"roughness_um": 50.0})
    rng = np.random.default_rng(0)
    values = [
        run_part(machine, _setpoints(robust), rng).measurements["finish-od"]["roughness_um"].value
        for _ in range(50)
    ]
    assert min(values) == 0.0


# ---------------------------------------------------------------------------- violations


def test_robust_setpoint_violates_nothing(robust):
    for seed in range(10):
        out = run_part(sample_machine(PLAN, seed), _setpoints(robust), np.random.default_rng(0))
        assert out.violations == ()


def test_setpoint_over_the_force_limit_is_a_violation(robust):
    machine = sample_machine(PLAN, 0)
    sp = _setpoints(robust)
    sp["rough-od"] = {"depth_mm": 3.0, "feed_mm_rev": 0.6, "speed_m_min": 200}
    out = run_part(machine, sp, np.random.default_rng(0))
    true = out.true_values["rough-od"]
    assert true["force_N"] > 2000
    found = {(v.operation, v.quantity): v for v in out.violations}
    assert found[("rough-od", "force_N")] == Violation("rough-od", "force_N", true["force_N"], 2000)
    assert found[("rough-od", "roughness_um")].limit == 4.0
    assert {v.operation for v in out.violations} == {"rough-od"}


def test_machine_limits_and_tool_life_are_checked(robust):
    machine = sample_machine(PLAN, 0)
    sp = _setpoints(robust)
    # 1000 m/min on Ø50: 6366 rpm > 4000; 0.4 mm/rev then 2546 mm/min is within 5000
    sp["rough-grooves"] = {"depth_mm": 1.0, "feed_mm_rev": 0.4, "speed_m_min": 1000}
    # 3000 m/min at 3 x 0.6 on Ø60: well over 22 kW, and an edge lasts about 5 parts (< 10)
    sp["rough-od"] = {"depth_mm": 3.0, "feed_mm_rev": 0.6, "speed_m_min": 3000}
    out = run_part(machine, sp, np.random.default_rng(0))
    found = {(v.operation, v.quantity): v for v in out.violations}
    grooves = out.true_values["rough-grooves"]
    assert found[("rough-grooves", "spindle_rpm")].limit == 4000
    assert_allclose(found[("rough-grooves", "spindle_rpm")].true_value, 1000e3 / (math.pi * 50))
    assert ("rough-grooves", "feed_rate_mm_min") not in found
    assert grooves["feed_rate_mm_min"] < 5000
    assert found[("rough-od", "power_kW")].limit == 22
    life = found[("rough-od", "parts_per_edge")]
    assert life.limit == 10
    assert_allclose(life.true_value, out.true_values["rough-od"]["tool_life_mm3"] / 86400)


def test_tighter_operation_limit_wins_over_the_machine():
    data = copy.deepcopy(ROUGH_OD)
    data["operations"][0]["limits"]["power_kW"] = 5.0
    plan = plan_from_mapping(data)
    machine = sample_machine(plan, 0)
    sp = {"rough-od": {"depth_mm": 3.0, "feed_mm_rev": 0.5, "speed_m_min": 200}}
    out = run_part(machine, sp, np.random.default_rng(0))
    power = out.true_values["rough-od"]["power_kW"]
    assert 5.0 < power < 22.0
    assert [v for v in out.violations if v.quantity == "power_kW"] == [
        Violation("rough-od", "power_kW", power, 5.0)
    ]


def test_true_value_at_the_limit_is_not_a_violation():
    plan = plan_from_mapping(ROUGH_OD)
    machine = sample_machine(plan, 9)
    force = machine.processes["rough-od"].tool.models["force_N"]
    d, v = 1.0, 150.0
    # feed at which the true force is exactly 2000 N
    e = force.exponents
    f = (2000 / (force.K * d ** e["depth_mm"] * v ** e["speed_m_min"])) ** (1 / e["feed_mm_rev"])
    rng = np.random.default_rng(0)
    at = run_part(machine, {"rough-od": {"depth_mm": d, "feed_mm_rev": f, "speed_m_min": v}}, rng)
    assert_allclose(at.true_values["rough-od"]["force_N"], 2000, rtol=1e-12)
    assert "force_N" not in {x.quantity for x in at.violations}
    over = {"depth_mm": d, "feed_mm_rev": f * 1.00001, "speed_m_min": v}
    out = run_part(machine, {"rough-od": over}, rng)
    assert "force_N" in {x.quantity for x in out.violations}


# ---------------------------------------------------------------------------- oracle


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_oracle_is_at_least_the_robust_optimum(robust, seed):
    machine = sample_machine(PLAN, seed)
    oracle = optimize_plan(PLAN, tools=oracle_tools(machine))
    for r, o in zip(robust.operations, oracle.operations, strict=True):
        assert o.mrr_cm3_min >= r.mrr_cm3_min * (1 - SOLVER_RTOL), r.name
        assert o.tool == r.tool
    assert oracle.cycle_time_min < robust.cycle_time_min
    # the oracle's optimum meets every true limit (up to the solver's tolerance)
    out = run_part(machine, _setpoints(oracle), np.random.default_rng(0))
    for v in out.violations:
        assert v.true_value <= v.limit * (1 + SOLVER_RTOL), v


# ---------------------------------------------------------------------------- tool wear


def test_wear_drift_raises_force_and_roughness_over_the_edge_life(robust):
    worn = sample_machine(PLAN, 6, wear_drift_per_edge_life=0.2)
    plain = VirtualMachine(PLAN, worn.processes, worn.uncertainty)  # the same truth, no drift
    # the catalogue band covers the worn edge too: a drifting quantity's new-edge truth is
    # drawn under the band's upper edge by the factor 1.05 (the force band is ±7 %), the rest
    # as without drift
    unworn = sample_machine(PLAN, 6)
    assert worn.processes["finish-od"] == unworn.processes["finish-od"]  # no tool-life model
    drifting = sample_machine(PLAN, 6, wear_drift_per_edge_life=0.05)
    op = OPS["rough-od"]
    for quantity in ("force_N", "roughness_um"):
        nominal = PLAN.tools[op.tool].models[quantity]
        true = drifting.processes["rough-od"].tool.models[quantity]
        for corner in itertools.product(
            *(op.bounds[p] for p in ("depth_mm", "feed_mm_rev", "speed_m_min"))
        ):
            point = {
                **op.context,
                **dict(zip(("depth_mm", "feed_mm_rev", "speed_m_min"), corner, strict=True)),
            }
            assert true.predict(point).value * 1.05 <= nominal.predict(point).upper * (1 + 1e-9)
    sp = _setpoints(robust)
    new = run_part(worn, sp, np.random.default_rng(0), {"rough-od": 0})
    used = run_part(worn, sp, np.random.default_rng(0), {"rough-od": 5, "finish-od": 5})
    base = run_part(plain, sp, np.random.default_rng(0), {"rough-od": 5})
    assert new.true_values == base.true_values
    life_parts = base.true_values["rough-od"]["tool_life_mm3"] / OPS["rough-od"].volume_mm3
    factor = 1 + 0.2 * 5 / life_parts
    for quantity in ("force_N", "roughness_um", "power_kW", "torque_Nm"):
        assert_allclose(
            used.true_values["rough-od"][quantity],
            base.true_values["rough-od"][quantity] * factor,
            rtol=1e-12,
        )
    assert (
        used.true_values["rough-od"]["tool_life_mm3"]
        == base.true_values["rough-od"]["tool_life_mm3"]
    )
    # no tool-life model, no drift
    assert used.true_values["finish-od"] == base.true_values["finish-od"]


def test_measured_flank_wear_inverts_the_true_tool_life(robust):
    machine = sample_machine(PLAN, 8, uncertainty={"flank_wear_mm": 0.0})
    setpoint = dict(robust.operations[0].setpoint)
    volume = 40 * 86400.0
    wear = measure_tool_wear(machine, "rough-od", setpoint, volume, np.random.default_rng(0))
    assert wear.volume_mm3 == volume
    life = machine.processes["rough-od"].tool.models["tool_life_mm3"]
    point = {**setpoint, "flank_wear_mm": wear.flank_wear_mm.value}
    assert_allclose(life.monomial.evaluate(point), volume, rtol=1e-12)
    with pytest.raises(InputError, match="tool-life"):
        measure_tool_wear(machine, "finish-od", setpoint, volume, np.random.default_rng(0))


# ---------------------------------------------------------------------------- inputs


def test_run_part_refuses_incomplete_setpoints(robust):
    machine = sample_machine(PLAN, 0)
    sp = _setpoints(robust)
    rng = np.random.default_rng(0)
    with pytest.raises(InputError, match="setpoints"):
        run_part(machine, {k: v for k, v in sp.items() if k != "finish-od"}, rng)
    bad = copy.deepcopy(sp)
    del bad["rough-od"]["feed_mm_rev"]
    with pytest.raises(InputError, match=r"setpoints\.rough-od\.feed_mm_rev"):
        run_part(machine, bad, rng)
    bad = copy.deepcopy(sp)
    bad["rough-od"]["depth_mm"] = -1.0
    with pytest.raises(InputError, match=r"setpoints\.rough-od\.depth_mm"):
        run_part(machine, bad, rng)
    bad = copy.deepcopy(sp)
    bad["rough-od"]["radial_depth_mm"] = 1.0
    with pytest.raises(InputError, match="radial_depth_mm"):
        run_part(machine, bad, rng)


def test_virtual_machine_checks_its_parts():
    machine = sample_machine(PLAN, 0)
    with pytest.raises(InputError, match="wear_drift"):
        replace(machine, wear_drift_per_edge_life=-1.0)
    with pytest.raises(InputError, match="uncertainty.roughness_um"):
        replace(machine, uncertainty={"force_N": 3.0})
    with pytest.raises(InputError, match="processes.finish-od"):
        replace(machine, processes={k: v for k, v in machine.processes.items() if k != "finish-od"})
    other = sample_machine(PLAN, 1)
    swapped = dict(machine.processes)
    swapped["rough-od"] = replace(swapped["rough-od"], tool=other.processes["finish-od"].tool)
    with pytest.raises(InputError, match="processes.rough-od.tool.models"):
        VirtualMachine(PLAN, swapped, machine.uncertainty)
