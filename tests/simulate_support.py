"""Helpers of the virtual-machine tests (tests/supervisor/test_simulate.py,
test_simulate_outcomes.py): the demonstration plan, a one-operation plan and a result's
setpoints."""

from __future__ import annotations

from supervisor.inputs.plan import load_plan

from conftest import DEMO_PLAN

PLAN = load_plan(DEMO_PLAN)
OPS = {op.name: op for op in PLAN.operations}

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


def _setpoints(result):
    return {op.name: dict(op.setpoint) for op in result.operations}
