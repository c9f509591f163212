"""Borangiu's productivity cost J as a selectable objective of a milling operation.

The operation: a Ø10 mm 4-flute end mill, force 1000·ap·ae·fz^0.75 N with ΔK = 100 (as in
test_optimizer's hand-solved milling case), force <= 2000 N, 8000 rpm; cost data of
examples/borangiu_domain.toml (tool 40, wage 1.0/min, energy 0.15/kWh, 0.3 kW for 3 min per
change, 5 min regrinding, steel 7.85 t/m³, Taylor v·T^0.25·fz^0.5 = 132).
"""

from __future__ import annotations

import copy
import json
import math
import tomllib
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from numpy.testing import assert_allclose

from api.cli.main import app
from models import borangiu_cost, kinematics
from models.errors import InputError
from supervisor.errors import InfeasibleError
from supervisor.inputs.plan import plan_from_mapping
from supervisor.inputs.resolution import DEFAULT_RESOLUTION
from supervisor.optimize import productivity
from supervisor.optimize.formulation import formulate
from supervisor.optimize.optimizer import optimize_operation, optimize_plan

ROOT = Path(__file__).resolve().parents[2]

COST = {
    "tool_cost": 40,
    "wage_rate_per_min": 1.0,
    "energy_cost_per_kWh": 0.15,
    "tool_change_power_kW": 0.3,
    "tool_change_time_min": 3,
    "regrinding_time_min": 5,
    "density_t_m3": 7.85,
    "taylor_speed_m_min": 132,
    "taylor_m": 0.25,
    "taylor_q": 0.5,
}
#: A resolution so fine that the setpoint is the continuous optimum to about 1e-7: these tests
#: check the optimiser's continuous optimum; tests/supervisor/test_setpoint_resolution.py the
#: grid. (The
#: geometric program's solver holds a row to about 2e-11 in ln, 3e-9 m/min at 157 m/min: the
#: step stays above that, so the grid rule finds the grid point next to the row.)
FINE = dict.fromkeys(DEFAULT_RESOLUTION, 1e-8)
PLAN = {
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
            "limits": {"force_N": 2000},
            "bounds": {
                "axial_depth_mm": [0.5, 2],
                "radial_depth_mm": [1, 5],
                "feed_per_tooth_mm": [0.02, 0.08],
                "speed_m_min": [50, 400],
            },
            "objective": "productivity",
            "productivity": COST,
        }
    ],
}
PER_LIFE = 40 + 0.15 * 0.3 * 3 / 60 + 1.0 * 5  # 45.00225 per tool life besides cutting
T_BEST = (1 / 0.25 - 1) * PER_LIFE / 1.0  # least-cost tool life (Shaw ch. 19): 135.007 min


def plan(**changes: Any) -> dict[str, Any]:
    data = copy.deepcopy(PLAN)
    data["operations"][0].update(changes)
    return data


def solve(data: dict[str, Any]):
    return optimize_plan(plan_from_mapping(data)).operations[0]


def J_by_hand(ap: float, ae: float, fz: float, v: float) -> float:
    """Eq. (1) divided by T: (cost of a life / T + wage + energy) / kg per min."""
    n = 1000 * v / (math.pi * 10)
    w = fz * 4 * n
    life = (132 / (v * fz**0.5)) ** (1 / 0.25)
    power = 1000 * ap * ae * fz**0.75 * v / 60000  # nominal force × v
    kg_per_min = 1e-6 * 7.85 * ap * ae * w
    return (PER_LIFE / life + 1.0 + 0.15 * power / 60) / kg_per_min


def test_least_cost_setpoint_is_hand_derived():
    # J falls with ap·ae (1/(ap·ae) in the tool and wage terms, F/(ap·ae) constant) and with
    # fz (q < 1), so ap, ae, fz go to their bounds 2, 5, 0.08 (force 1100·10·0.08^0.75 =
    # 1654 N <= 2000). In v the energy term F·v/w is constant, so v is the classic least-cost
    # speed: T(v) = 135.007 min, v = 132/(135.007^0.25·0.08^0.5) = 136.912 m/min.
    v = 132 / (T_BEST**0.25 * 0.08**0.5)
    assert_allclose(v, 136.912, rtol=1e-5)
    op = solve(plan())
    assert op.objective == "productivity"
    s = op.setpoint
    assert_allclose(
        [s["axial_depth_mm"], s["radial_depth_mm"], s["feed_per_tooth_mm"]], [2, 5, 0.08]
    )
    assert_allclose(s["speed_m_min"], v, rtol=1e-4)
    assert set(op.binding) == {"axial_depth_mm", "radial_depth_mm", "feed_per_tooth_mm"}
    assert_allclose(op.cost_per_kg, J_by_hand(2, 5, 0.08, v), rtol=1e-8)
    assert_allclose(op.cost_per_kg, 12.2579, rtol=1e-4)
    assert_allclose(op.mrr_cm3_min, 2 * 5 * 0.08 * 4 * 1000 * v / (math.pi * 10) / 1000, rtol=1e-4)


def test_max_mrr_is_unchanged_by_cost_data_and_costs_more():
    # max MRR: everything at its bound and the spindle at 8000 rpm (v = 251.33 m/min)
    fastest = solve(plan(objective="mrr"))
    data = plan(objective="mrr")
    del data["operations"][0]["productivity"]
    without = solve(data)
    assert fastest.setpoint == without.setpoint and fastest.binding == without.binding
    assert without.cost_per_kg is None and without.objective == "mrr"
    assert_allclose(fastest.setpoint["speed_m_min"], 8000 * math.pi * 10 / 1000)
    assert_allclose(fastest.cost_per_kg, J_by_hand(2, 5, 0.08, 251.327), rtol=1e-5)
    cheapest = solve(plan())
    assert cheapest.cost_per_kg < fastest.cost_per_kg  # 12.26 < 23.89 /kg
    assert cheapest.mrr_cm3_min < fastest.mrr_cm3_min


def test_domain_rows_bind_in_both_objectives():
    # K_d = 0.2 mm/rev on fz·z: fz <= 0.05, then v = 132/(135.007^0.25·0.05^0.5) = 173.18
    domain = {"max_deflection_feed_mm_rev": 0.2, "min_spindle_rpm": 100}
    cheapest = solve(plan(domain=domain))
    assert_allclose(cheapest.setpoint["feed_per_tooth_mm"], 0.05, rtol=1e-6)
    assert_allclose(cheapest.setpoint["speed_m_min"], 132 / (T_BEST**0.25 * 0.05**0.5), rtol=1e-4)
    assert "domain.max_deflection_feed_mm_rev" in cheapest.binding
    fastest = solve(plan(domain=domain, objective="mrr"))
    assert_allclose(fastest.setpoint["feed_per_tooth_mm"], 0.05, rtol=1e-9)
    assert "domain.max_deflection_feed_mm_rev" in fastest.binding


def test_a_domain_minimum_binds_the_cost_optimum():
    # n >= 5000 rpm: v >= 5000·π·10/1000 = 157.08 m/min, above the least-cost 136.91; J is
    # convex in ln v, so the optimum sits on the minimum
    op = solve(plan(domain={"min_spindle_rpm": 5000}))
    assert_allclose(op.setpoint["speed_m_min"], 5000 * math.pi * 10 / 1000, rtol=1e-7)
    assert "domain.min_spindle_rpm" in op.binding
    assert op.cost_per_kg > 12.2579


def test_domain_power_row_is_borangiu_eq7_in_fz_and_v():
    # P = 3.1e-4·w^0.75·n^0.25 <= 0.5 kW at fz = 0.08 (w/n = 0.32): n = 0.5/3.1e-4/0.32^0.75
    # = 3792.8 rpm, i.e. v = 119.15 m/min for max MRR
    domain = {"power_exponent": 0.75, "power_coefficient_kW": 3.1e-4, "max_power_kW": 0.5}
    op = solve(plan(domain=domain, objective="mrr"))
    n = 0.5 / 3.1e-4 / 0.32**0.75
    assert_allclose(op.setpoint["speed_m_min"], n * math.pi * 10 / 1000, rtol=1e-7)
    assert "domain.max_power_kW" in op.binding


def test_the_operation_program_is_dgp_and_dpp_and_reused():
    data = plan_from_mapping(plan())
    op = data.operations[0]
    tool = data.tools[op.tool]
    lp = formulate(op, tool, data.machine)
    problem = productivity.dgp_problem(lp)
    assert problem.is_dgp(dpp=True) and problem.is_dpp("dgp")
    before = productivity._program.cache_info()
    narrower = replace(tool, models={"force_N": replace(tool.models["force_N"], dK=10.0)})
    optimize_operation(op, tool, data.machine)
    optimize_operation(op, narrower, data.machine)  # only a band changed: same structure
    after = productivity._program.cache_info()
    assert after.misses == before.misses and after.hits >= before.hits + 2


def test_force_limit_binds_under_the_cost_objective():
    # force <= 1000 N: 1100·ap·ae·0.08^0.75 <= 1000 gives ap·ae = 6.04 mm² < 10; J still falls
    # with ap·ae, so the force row binds; fz stays 0.08 (J and F/(ap ae) both favour it)
    op = solve(plan(limits={"force_N": 1000}))
    assert "force_N" in op.binding
    assert_allclose(op.predicted["force_N"].upper, 1000, rtol=1e-6)


def test_infeasible_productivity_operation_names_the_conflict():
    # K_fm = 0.5 mm/rev needs fz >= 0.125 > 0.08
    with pytest.raises(InfeasibleError) as err:
        solve(plan(domain={"min_pitch_feed_mm_rev": 0.5}))
    assert "domain.min_pitch_feed_mm_rev >= 0.5 can reach at most 0.32" in str(err.value)
    assert "feed_per_tooth_mm <= 0.08" in str(err.value)


TURNING = {
    "name": "rough-od",
    "tool": "CNMG432RN",
    "workpiece_diameter_mm": 60,
    "volume_mm3": 86400,
    "bounds": {"depth_mm": [0.5, 3.0], "feed_mm_rev": [0.1, 0.6], "speed_m_min": [100, 200]},
}
NO_FORCE_TOOL = {
    "name": "EM-wear",
    "process": "milling",
    "models": {"tool_life_mm3": {"K": 1e6, "exponents": {"speed_m_min": -2}}},
}


def _turning(**extra: Any) -> dict[str, Any]:
    machine = {"name": "lathe", "resolution": FINE}
    return {"name": "t", "machine": machine, "operations": [TURNING | extra]}


def _no_force(**extra: Any) -> dict[str, Any]:
    data = plan(tool="EM-wear", limits={}, **extra)
    data["tools"].append(NO_FORCE_TOOL)
    return data


@pytest.mark.parametrize(
    ("data", "field", "fragment"),
    [
        (plan(objective="speed"), "operations[0].objective", "expected one of: mrr, productivity"),
        (plan(productivity=None), "operations[0].productivity", "must be a table"),
        (
            plan(productivity=COST | {"tool_cost_eur": 3}),
            "operations[0].productivity.tool_cost_eur",
            "unknown field",
        ),
        (
            plan(productivity={k: v for k, v in COST.items() if k != "taylor_m"}),
            "operations[0].productivity.taylor_m",
            "required",
        ),
        (
            plan(productivity=COST | {"taylor_m": 1.2}),
            "operations[0].productivity.taylor_m",
            "(0, 1)",
        ),
        (
            plan(productivity=COST | {"wage_rate_per_min": 0}),
            "operations[0].productivity.wage_rate_per_min",
            "greater than 0",
        ),
        (
            plan(productivity={"a": 1, "b": 0, "c": 1, "q": 0.5, "m": 0.25, "yp": 0.75}),
            "operations[0].productivity.a",
            "an operation's depths vary",
        ),
        (plan(domain={"max_torque_Nm": 3}), "operations[0].domain.max_torque_Nm", "unknown field"),
        (
            plan(domain={"min_spindle_rpm": 900, "max_spindle_rpm": 800}),
            "operations[0].domain.min_spindle_rpm",
            "above",
        ),
        (plan(domain={"max_power_kW": 2}), "operations[0].domain.power_exponent", "Eq. 7 needs"),
        (plan(domain={}), "operations[0].domain", "give at least one"),
        (_turning(domain={"max_pitch_feed_mm_rev": 0.5}), "operations[0].domain", "milling"),
        (_turning(objective="productivity"), "operations[0].objective", "milling"),
        (_no_force(), "operations[0].productivity.energy_cost_per_kWh", "has none"),
    ],
)
def test_plan_errors_name_the_field(data, field, fragment):
    with pytest.raises(InputError) as err:
        plan_from_mapping(data)
    assert err.value.field == field
    assert fragment in str(err.value)


def test_objective_without_its_table_is_refused():
    data = plan()
    del data["operations"][0]["productivity"]
    with pytest.raises(InputError) as err:
        plan_from_mapping(data)
    assert err.value.field == "operations[0].productivity"
    assert "required with this objective" in str(err.value)


def test_a_tool_without_force_model_is_fine_at_zero_energy_cost():
    op = solve(_no_force(productivity=COST | {"energy_cost_per_kWh": 0}))
    assert_allclose(op.setpoint["feed_per_tooth_mm"], 0.08)
    assert_allclose(op.setpoint["speed_m_min"], 132 / (T_BEST**0.25 * 0.08**0.5), rtol=1e-4)


def _toml(data: dict[str, Any]) -> str:
    """Just enough TOML for these plans (tables of numbers and strings, lists of tables)."""

    def value(v: Any) -> str:
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + " }"
        return json.dumps(v)

    lines = [f"name = {value(data['name'])}", f"machine = {value(data['machine'])}"]
    for key in ("tools", "operations"):
        for entry in data.get(key, []):
            lines.append(f"[[{key}]]")
            lines += [f"{k} = {value(v)}" for k, v in entry.items()]
    return "\n".join(lines) + "\n"


def test_rcb_optimize_runs_a_productivity_plan_and_refuses_bad_fields(runner, tmp_path):
    path = tmp_path / "plan.toml"
    path.write_text(_toml(plan()), encoding="utf-8")
    assert tomllib.loads(path.read_text())["operations"][0]["objective"] == "productivity"
    good = runner.invoke(app, ["optimize", str(path), "--json"])
    assert good.exit_code == 0, good.output
    speed = json.loads(good.stdout)["operations"][0]["setpoint"]["speed_m_min"]
    assert_allclose(speed, 136.912, rtol=1e-4)
    path.write_text(_toml(plan(productivity=COST | {"taylor_q": 1.5})), encoding="utf-8")
    bad = runner.invoke(app, ["optimize", str(path)])
    assert bad.exit_code == 2
    assert bad.stderr.strip().splitlines() == [
        "rcb: error: operations[0].productivity.taylor_q = 1.5: Taylor's feed exponent must lie "
        "in [0, 1): with q >= 1 a larger pitch feed would not lower J (Borangiu Eqs. 10-12)"
    ]


def test_cost_terms_are_eq1_over_tool_life():
    # J = (cost of a life/T + C_t + C_e·P_c/60) / (1e-6·ρ·ap·ae·w) at an arbitrary point
    cost = borangiu_cost.productivity_from_mapping(COST, "p")
    assert isinstance(cost, borangiu_cost.CostData)
    assert_allclose(cost.cost_per_tool_life, 45.00225)
    assert_allclose(cost.min_cost_tool_life_min(), 135.00675)
    force = plan_from_mapping(plan()).tools["EM10"].models["force_N"].monomial
    terms = borangiu_cost.milling_cost_terms(cost, force * kinematics.power_per_newton_monomial())
    point = {
        "axial_depth_mm": 1.5,
        "radial_depth_mm": 3.0,
        "feed_per_tooth_mm": 0.05,
        "speed_m_min": 180.0,
        "tool_diameter_mm": 10,
        "flute_count": 4,
    }
    assert_allclose(borangiu_cost.evaluate(terms, point), J_by_hand(1.5, 3.0, 0.05, 180.0))
