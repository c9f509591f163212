"""benchmarks/gp_baseline.py: one short scenario of the constrained-BO baseline."""

from __future__ import annotations

import importlib
import importlib.util
import math
import sys
from pathlib import Path

import pytest

from supervisor.inputs.plan import load_plan
from supervisor.optimize.optimizer import optimize_plan
from supervisor.rcb.update import start
from supervisor.virtual.sampling import oracle_tools, sample_machine

ROOT = Path(__file__).resolve().parents[2]
DEMO_PLAN = ROOT / "examples" / "ivester_demo_part.toml"

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("sklearn") is None,
    reason=(
        "scikit-learn not installed: the GP baseline needs the bench extra "
        '(pip install -e ".[bench]")'
    ),
)


def _gp_baseline():
    benchmarks = str(ROOT / "benchmarks")
    if benchmarks not in sys.path:
        sys.path.insert(0, benchmarks)
    return importlib.import_module("gp_baseline")


def test_one_scenario_of_three_parts():
    plan = load_plan(DEMO_PLAN)
    seed, parts = 3, 3
    trace = _gp_baseline().run_gp_scenario(plan, seed, parts)
    assert len(trace.mrr_over_oracle) == parts + 1
    assert len(trace.violations) == parts
    oracle = optimize_plan(plan, tools=oracle_tools(sample_machine(plan, seed)))
    robust = start(plan).setpoints
    assert trace.mrr_over_oracle[0] == pytest.approx(
        oracle.cycle_time_min / robust.cycle_time_min, rel=1e-12
    )
    assert all(math.isfinite(r) and r > 0 for r in trace.mrr_over_oracle)
    assert all(isinstance(v, int) and v >= 0 for v in trace.violations)
    assert trace.seconds > 0
