"""The virtual machine's outcomes: violations of the true limits, the oracle, tool wear, and
its refusals."""

from __future__ import annotations

import copy
import itertools
import math
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose
from simulate_support import OPS, PLAN, ROUGH_OD, _setpoints

from models.errors import InputError
from supervisor.inputs.plan import plan_from_mapping
from supervisor.optimize.optimizer import optimize_plan
from supervisor.virtual.machine import Violation, VirtualMachine
from supervisor.virtual.sampling import oracle_tools, sample_machine
from supervisor.virtual.simulate import measure_tool_wear, run_part


@pytest.fixture(scope="module")
def robust():
    return optimize_plan(PLAN)


#: Solver tolerance of an optimum's removal rate (supervisor.optimize.solve.RECHECK_RTOL).
SOLVER_RTOL = 1e-6


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
