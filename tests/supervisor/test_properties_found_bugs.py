"""Deterministic tests of the bugs the property tests (test_properties.py) found in the robust
optimiser: a warm start that failed, a conflict left unnamed, a feasible program called infeasible.
"""

from __future__ import annotations

from typing import Any

import pytest
from property_support import ISO_3685_VB_MM, LIMIT_RTOL, TOOL, robust_edges, solve

from supervisor.errors import InfeasibleError
from supervisor.inputs.plan import plan_from_mapping
from supervisor.optimize.optimizer import optimize_plan

from conftest import FINE


def two_tool_plan(operations: list[str]) -> dict[str, Any]:
    """Operations ``a`` (feasible) and ``b`` (infeasible), with 6 rows each: one cached program.

    Found by the properties of test_properties.py; tool B's depth exponent of 1e-7 is what
    makes the solver's warm start from ``a``'s optimum fail.
    """
    tools = [
        {
            "name": "A",
            "process": "turning",
            "models": {
                "force_N": {"K": 3000.0, "exponents": {"feed_mm_rev": 1.0}},
                "spindle_current_A": {"K": 1.0, "exponents": {"feed_mm_rev": 1.0}},
                "tool_life_mm3": {"K": 2e7},
            },
        },
        {
            "name": "B",
            "process": "turning",
            "models": {
                "force_N": {
                    "K": 3000.0,
                    "exponents": {"depth_mm": 1e-7, "feed_mm_rev": 0.69, "speed_m_min": 0.04},
                },
                "roughness_um": {"K": 10.0, "exponents": {"depth_mm": 0.7, "feed_mm_rev": 1.49}},
                "tool_life_mm3": {"K": 1e9},
            },
        },
    ]
    ops = {
        "a": {
            "name": "a",
            "tool": "A",
            "workpiece_diameter_mm": 110.0,
            "volume_mm3": 90000.0,
            "limits": {
                "force_N": 300.0,
                "spindle_current_A": 0.2,
                "parts_per_edge": 0.06,
                "power_kW": 0.5,
                "spindle_rpm": 200.0,
                "feed_rate_mm_min": 80.0,
            },
            "bounds": {
                "depth_mm": [1.0, 3.0],
                "feed_mm_rev": [0.04, 0.2],
                "speed_m_min": [66.0, 100.0],
            },
        },
        "b": {
            "name": "b",
            "tool": "B",
            "workpiece_diameter_mm": 200.0,
            "volume_mm3": 50000.0,
            "limits": {
                "force_N": 700.0,
                "roughness_um": 0.8,
                "parts_per_edge": 8.0,
                "power_kW": 20.0,
                "spindle_rpm": 3000.0,
                "torque_Nm": 100.0,
            },
            "bounds": {
                "depth_mm": [1.0, 4.0],
                "feed_mm_rev": [0.12, 0.3],
                "speed_m_min": [80.0, 300.0],
            },
        },
    }
    return {
        "name": "two-tools",
        "machine": {"name": "lathe", "resolution": FINE},
        "tools": tools,
        "operations": [ops[name] for name in operations],
    }


def test_an_infeasible_operation_stays_infeasible_after_a_feasible_one():
    # Failed at e73a820: the cached program warm-started HiGHS with a's optimum, b then got
    # status kUnknown and cvxpy's ValueError("Cannot unpack invalid solution") escaped. At
    # 3aebb94 (presolve off) b alone ended kUnknown and raised the same ValueError.
    with pytest.raises(InfeasibleError) as alone:
        optimize_plan(plan_from_mapping(two_tool_plan(["b"])))
    assert alone.value.operation == "b"
    with pytest.raises(InfeasibleError) as after:
        optimize_plan(plan_from_mapping(two_tool_plan(["a", "b"])))
    assert after.value.operation == "b"


def test_a_limit_slightly_too_tight_is_named_as_the_conflict():
    # Failed at e73a820: the diagnosis named a row only beyond BINDING_TOL = 1e-6 in ln while
    # HiGHS calls the program infeasible beyond about 1e-7, so a limit 0.5 ppm too tight gave
    # an InfeasibleError with no conflict and force_N listed as "held by".
    # The force is 2000·d·f, least at the lower corner: 200 N; the limit is 0.5 ppm below it.
    limit = 200.0 * (1 - 5e-7)
    data = {
        "name": "tight",
        "machine": {"name": "lathe", "resolution": FINE},
        "tools": [
            {
                "name": TOOL,
                "process": "turning",
                "models": {
                    "force_N": {"K": 2000.0, "exponents": {"depth_mm": 1, "feed_mm_rev": 1}}
                },
            }
        ],
        "operations": [
            {
                "name": "rough",
                "tool": TOOL,
                "workpiece_diameter_mm": 50.0,
                "volume_mm3": 1000.0,
                "limits": {"force_N": limit},
                "bounds": {
                    "depth_mm": [1.0, 2.0],
                    "feed_mm_rev": [0.1, 0.2],
                    "speed_m_min": [100.0, 200.0],
                },
            }
        ],
    }
    with pytest.raises(InfeasibleError) as info:
        solve(data)
    assert [c.name for c in info.value.conflicts] == ["force_N"]
    assert "force_N <=" in str(info.value)


def test_a_power_limit_just_above_its_least_value_is_met():
    # Failed at e73a820 and dd5f149: HiGHS presolve called this feasible program infeasible,
    # and the diagnosis, finding no slack, named a conflict whose required == limit.
    # Power F·v/60000 with F = 148.41316·d^5.1e-6·f^0.375 is least at the lower corner of the
    # bounds, 0.0928193789 kW: the lower corner meets the limit with 2 ppm to spare.
    limit = 0.092819564
    force = {"K": 148.41316, "exponents": {"depth_mm": 5.1e-6, "feed_mm_rev": 0.375}}
    bounds = {
        "depth_mm": [1.0, 1.5],
        "feed_mm_rev": [0.36787944, 0.7],
        "speed_m_min": [54.59815, 100],
    }
    models = {"force_N": {**force, "dK": 0.0}}
    context = {"workpiece_diameter_mm": 20.0, "flank_wear_mm": ISO_3685_VB_MM}
    lower_corner = {p: lo for p, (lo, _) in bounds.items()}
    assert robust_edges(models, lower_corner, context, {})["power_kW"] < limit * (1 - 1e-6)
    data = {
        "name": "thin",
        "machine": {"name": "lathe", "max_power_kW": limit, "resolution": FINE},
        "tools": [{"name": TOOL, "process": "turning", "models": {"force_N": force}}],
        "operations": [
            {
                "name": "finish",
                "tool": TOOL,
                "workpiece_diameter_mm": 20.0,
                "volume_mm3": 1000.0,
                "bounds": bounds,
            }
        ],
    }
    power = robust_edges(models, solve(data).setpoint, context, {})["power_kW"]
    assert power <= limit * (1 + LIMIT_RTOL)
