"""A reading stated to be near exact is counted with the least uncertainty a chain can claim.

An MES sent ``force_N = {value: <the prediction>, uncertainty: 1e-9}`` (the schema takes any
``u > 0``): ``learn`` took it as exact, its posterior lost its positive definiteness and the
next setpoints were past the force limit (depth 3.0, feed 0.4 at a predicted 1e-7 N where the
law gives 1440 N against 600), or every later report of the plan failed in the Cholesky
factor (500, the part never stored). A reading is now counted with at least
:data:`~supervisor.inputs.part_report.LEAST_REL_UNCERTAINTY` of its value.
"""

from __future__ import annotations

import pytest

from models.powerlaw import PowerLawModel
from models.tool import Tool
from supervisor.inputs.part_report import LEAST_REL_UNCERTAINTY, Measurement, counted
from supervisor.inputs.plan import load_plan
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start
from supervisor.virtual.machine import DEFAULT_UNCERTAINTY, TrueProcess, VirtualMachine
from supervisor.virtual.scenario import run_machine

from conftest import DEMO_PLAN


def test_the_least_is_half_the_tightest_chain_of_the_paper():
    # Ivester & Heigel Table 5: a force read to ±2 N, 0.1 % of the paper's 2000 N force limit
    assert LEAST_REL_UNCERTAINTY == pytest.approx(0.5 * 2.0 / 2000.0)


@pytest.mark.parametrize(
    ("stated", "counted_u"), [(1e-9, 0.3), (0.0, 0.3), (0.29, 0.3), (0.3, 0.3), (3.0, 3.0)]
)
def test_a_reading_is_counted_with_at_least_the_least_uncertainty(stated, counted_u):
    reading = counted(Measurement(600.0, stated))
    assert (reading.value, reading.uncertainty) == (600.0, pytest.approx(counted_u))


def test_a_zero_reading_keeps_its_uncertainty():
    assert counted(Measurement(0.0, 0.0)) == Measurement(0.0, 0.0)


def _exact_machine(plan, stated_u):
    """The catalogue law's truth read by chains that state (and draw) ``stated_u``."""
    processes = {}
    for op in plan.operations:
        nominal = plan.tools[op.tool]
        models = {
            q: PowerLawModel(q, m.K, 0.0, dict(m.exponents)) for q, m in nominal.models.items()
        }
        processes[op.name] = TrueProcess(op.name, Tool(nominal.name, nominal.process, models))
    return VirtualMachine(plan, processes, dict.fromkeys(DEFAULT_UNCERTAINTY, stated_u))


@pytest.mark.parametrize("stated_u", [1e-9, 1e-6])
def test_learn_runs_on_readings_stated_near_exact_and_crosses_no_limit(stated_u):
    """Before: LinAlgError ("Matrix is not positive definite") at the second part's report."""
    plan = load_plan(DEMO_PLAN)
    state = start(plan, RcbSettings(strategy="learn"))
    trace, after = run_machine(state, _exact_machine(plan, stated_u), 0, 8)
    assert trace.stopped_at == 0 and trace.violations.sum() == 0
    assert trace.plan_ratio[-1] > 0.99  # readings that are near exact do teach the optimum
    assert after.version > 3
