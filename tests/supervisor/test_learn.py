"""The learn strategy: its posterior, its cone program, and RCB against a pessimistic truth."""

from __future__ import annotations

import math
from dataclasses import replace

import cvxpy as cp
import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from models.powerlaw import PowerLawModel
from models.tool import Tool
from supervisor.inputs.part_report import Measurement, PartReport
from supervisor.inputs.plan import load_plan
from supervisor.optimize import socp
from supervisor.optimize.formulation import formulate
from supervisor.optimize.optimizer import optimize_plan
from supervisor.rcb import posterior as post
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.strategies import REGISTRY
from supervisor.rcb.update import learned_cones, start, update
from supervisor.virtual.machine import DEFAULT_UNCERTAINTY, TrueProcess, VirtualMachine
from supervisor.virtual.simulate import run_part

from conftest import DEMO_PLAN

RELATIVE_MRR_TOL = 1e-6


@pytest.fixture(scope="module")
def plan():
    return load_plan(DEMO_PLAN)


def _scaled_machine(plan, factor):
    """A true process at ``factor`` x every nominal model (no band, no exponent error)."""
    processes = {}
    for op in plan.operations:
        nominal = plan.tools[op.tool]
        models = {
            q: PowerLawModel(q, m.K * factor, 0.0, dict(m.exponents))
            for q, m in nominal.models.items()
        }
        processes[op.name] = TrueProcess(op.name, Tool(nominal.name, nominal.process, models))
    return VirtualMachine(plan, processes, dict(DEFAULT_UNCERTAINTY))


def test_the_registry_names_every_strategy():
    assert set(REGISTRY) == {"learn", "ivester", "bayes"}
    assert all(s.summary for s in REGISTRY.values())


def test_prior_is_the_catalogue_model_at_the_box_centre(plan):
    op = plan.operations[0]  # rough-od: force K = 1720, exponents d 0.98? (the plan's tool)
    model = plan.tools[op.tool].models["force_N"]
    belief = post.prior(model, op, coverage_k=2.0, exponent_sd=0.15)
    centre = {n: math.exp(c) for n, c in zip(belief.names, belief.center, strict=True)}
    point = {**op.context, **centre}
    assert_allclose(belief.mean[0], math.log(model.predict(point).value))
    assert_allclose(belief.cov[0][0], ((model.dK / model.K) / 2.0) ** 2)
    assert belief.edge_max == 9  # parts_per_edge = 10: the edge-age feature, prior mean 0
    assert belief.mean[-1] == 0.0
    assert_allclose(math.sqrt(belief.cov[-1][-1]), post.DEFAULT_EDGE_SD / 9)
    for i, name in enumerate(belief.names, start=1):
        assert_allclose(belief.mean[i], model.exponents[name])
        assert_allclose(math.sqrt(belief.cov[i][i]), 0.15 * abs(model.exponents[name]))
    # the posterior mean as a power law is the catalogue model again
    assert_allclose(belief.model().predict(point).value, model.predict(point).value)
    assert post.from_json(belief.to_json()) == belief


def test_exact_measurements_teach_the_true_exponents(plan):
    # Measurements of a power law with other exponents, at points spread over the box, with
    # a tiny uncertainty: the posterior mean goes to the true K and exponents.
    op = plan.operations[0]
    model = plan.tools[op.tool].models["force_N"]
    true = PowerLawModel("force_N", model.K * 1.1, 0.0, {**model.exponents, "feed_mm_rev": 0.8})
    belief = post.prior(model, op, 2.0, 0.15)
    rng = np.random.default_rng(0)
    for _ in range(40):
        point = dict(op.context)
        for name in belief.names:
            lo, hi = op.bounds[name]
            point[name] = math.exp(rng.uniform(math.log(lo), math.log(hi)))
        y = true.predict(point).value
        belief = post.observe(belief, point, Measurement(y, y * 1e-6), 2.0, 0.0, edge_parts=0)
    learned = dict(zip(belief.names, belief.exponent_means, strict=True))
    assert_allclose(learned["feed_mm_rev"], 0.8, atol=1e-4)
    assert belief.observations == 40


def test_cone_program_matches_cvxpy(plan):
    # A learned program solved by supervisor.optimize.socp equals cvxpy's (Clarabel) solution of the
    # same second-order-cone program written out independently.
    state = start(plan, RcbSettings(strategy="learn"))
    op = plan.operations[0]
    result = state.setpoints.operations[0]
    point = {**result.setpoint, **op.context}
    y = 0.9 * result.predicted["force_N"].value
    report = PartReport("L-1", 1, {op.name: {"force_N": Measurement(y, 3.0)}})
    new, _ = update(state, report)
    cones = learned_cones(new)[op.name]
    lp = formulate(op, new.tools[op.name], plan.machine, cones)
    status, x = socp.maximize(lp)
    assert status == "optimal"
    v = cp.Variable(len(lp.parameters))
    constraints = [v >= np.array(lp.lower), v <= np.array(lp.upper)]
    for row in lp.rows:
        lhs = np.array(row.coefficients) @ v
        if row.cone is not None:
            G, h = np.array(row.cone.G), np.array(row.cone.h)
            lhs = lhs + row.cone.z * cp.norm(G @ v + h, 2)
        margin = socp.CONE_MARGIN if row.cone is not None else 0.0  # the same program
        constraints.append(lhs <= row.rhs - margin)
    problem = cp.Problem(cp.Maximize(np.array(lp.objective) @ v), constraints)
    problem.solve(solver=cp.CLARABEL)
    # the same optimal ln(MRR) (the optimum may be a face: compare values, not points), and
    # supervisor.optimize.socp's point meets every row of cvxpy's program
    assert_allclose(np.dot(lp.objective, x), problem.value, atol=1e-7)
    v.value = x
    assert max(float(np.max(c.violation())) for c in constraints) <= 1e-8
    assert point  # the part's setpoint was inside the box


@pytest.mark.parametrize("seed", [7, 8])
@pytest.mark.parametrize("strategy", ["ivester", "learn"])
def test_pessimistic_truth_never_backs_off_and_never_flags(plan, strategy, seed):
    # The true process is 0.95 x the model everywhere: every part comes out better than
    # predicted. The one-sided law never widens a band for that, so the setpoints' MRR does
    # not decrease from one part to the next and no decision is flagged (issue 15). learn runs
    # at the physical limit, where a reading past the limit by more than u (its 2σ) comes
    # once in 44: the note past_limit, never a flag (the alarm is 3σ, supervisor.rcb.law).
    machine = _scaled_machine(plan, 0.95)
    rng = np.random.default_rng(seed)
    state = start(plan, RcbSettings(strategy=strategy))
    previous = {op.name: op.mrr_cm3_min for op in state.setpoints.operations}
    for k in range(20):
        setpoints = {op.name: op.setpoint for op in state.setpoints.operations}
        outcome = run_part(machine, setpoints, rng)
        assert outcome.violations == ()
        state, decisions = update(state, PartReport(f"P-{k}", state.version, outcome.measurements))
        assert state.halt is None
        assert not [d for d in decisions if d.flagged]
        for op in state.setpoints.operations:
            assert op.mrr_cm3_min >= previous[op.name] * (1 - RELATIVE_MRR_TOL), (k, op.name)
            previous[op.name] = op.mrr_cm3_min


def test_a_cone_setpoint_alarms_only_past_three_sigma(plan):
    # A learn setpoint held by a cone bounds the true value: a reading past the limit by more
    # than u (2σ) but less than 3σ is the note past_limit; beyond 3σ it is a breach.
    machine = _scaled_machine(plan, 1.0)
    rng = np.random.default_rng(3)
    state = start(plan, RcbSettings(strategy="learn"))
    for k in range(5):
        setpoints = {op.name: op.setpoint for op in state.setpoints.operations}
        outcome = run_part(machine, setpoints, rng)
        state, _ = update(state, PartReport(f"C-{k}", state.version, outcome.measurements))
    held = next(
        op
        for op in state.setpoints.operations
        if op.robust_by == "cone" and "roughness_um" in op.binding
    )
    limit = next(o for o in plan.operations if o.name == held.name).limits["roughness_um"]
    u = 0.05

    def one(y):
        report = PartReport("C-x", state.version, {held.name: {"roughness_um": Measurement(y, u)}})
        new, (d,) = update(state, report)
        return d, next(op for op in new.setpoints.operations if op.name == held.name)

    between, _ = one(limit + 1.2 * u)  # y − u = limit + 0.01, y − 1.5u = limit − 0.015
    assert between.flag is None and between.note == "past_limit"
    assert not between.flagged
    beyond, after = one(limit + 1.6 * u)  # y − 1.5u = limit + 0.005
    # and, 4σ past what the posterior expects there, a change of the process (issue 27)
    assert beyond.flag == "breach" and beyond.flagged and beyond.note == "regime_change"
    assert after.mrr_cm3_min < held.mrr_cm3_min  # the posterior takes it in: it backs off


def test_learn_is_never_slower_than_its_fallback_band(plan):
    machine = _scaled_machine(plan, 1.0)
    rng = np.random.default_rng(3)
    state = start(plan, RcbSettings(strategy="learn"))
    assert state.setpoints == optimize_plan(plan)  # the first setpoint: the band optimum
    for k in range(5):
        setpoints = {op.name: op.setpoint for op in state.setpoints.operations}
        outcome = run_part(machine, setpoints, rng)
        state, _ = update(state, PartReport(f"B-{k}", state.version, outcome.measurements))
        band = optimize_plan(plan, state.tools)
        for mine, fallback in zip(state.setpoints.operations, band.operations, strict=True):
            assert mine.mrr_cm3_min >= fallback.mrr_cm3_min * (1 - RELATIVE_MRR_TOL)
    assert any(op.robust_by == "cone" for op in state.setpoints.operations)
    # a cone-held optimum names the learned limit it sits on (its spread counted)
    held = [op for op in state.setpoints.operations if op.robust_by == "cone"]
    assert any({"force_N", "roughness_um"} & set(op.binding) for op in held)


def test_a_grown_band_with_no_setpoint_halts_instead_of_raising(plan):
    # rough-od reported at 6000 N and then at 10000 N: the second part's band leaves no
    # setpoint under the 2000 N limit; the state halts, the setpoints stay those in force.
    # halt_over 10 (1000 %): the gross-breach halt is test_a_gross_breach_halts_every_strategy's
    state = start(plan, RcbSettings(strategy="ivester", halt_over=10.0))
    for k, force in enumerate((6000.0, 10000.0)):
        report = PartReport(
            f"H-{k}", state.version, {"rough-od": {"force_N": Measurement(force, 10)}}
        )
        before = state
        state, (d,) = update(state, report)
        assert d.flag == "breach" and d.action == "expand"
    assert state.halt is not None
    assert [o.operation for o in state.halt.operations] == ["rough-od"]
    assert state.halt.operations[0].conflicts
    assert state.setpoints == before.setpoints and state.version == before.version
    # still halted after another report, and a replan-free resume is impossible
    report = PartReport("H-2", state.version, {"rough-od": {"force_N": Measurement(100.0, 10)}})
    again, _ = update(state, report)
    assert again.halt is not None and again.version == state.version
    assert replace(again, halt=None).halt is None


@pytest.mark.parametrize("strategy", ["learn", "ivester", "bayes"])
def test_a_gross_breach_halts_every_strategy(plan, strategy):
    # 6000 ± 10 N on rough-od's 2000 N limit: (6000 - 10) / 2000 - 1 = 199.5 % past it, more
    # than halt_over 25 %: the plan halts at once whatever a strategy could still find (issue
    # 27); 2400 ± 10 N is 19.5 % past: a breach that backs off, no halt.
    state = start(plan, RcbSettings(strategy=strategy))
    near, (d,) = update(
        state, PartReport("G-0", 1, {"rough-od": {"force_N": Measurement(2400.0, 10)}})
    )
    assert near.halt is None and d.flag == "breach"
    halted, _ = update(
        state, PartReport("G-1", 1, {"rough-od": {"force_N": Measurement(6000.0, 10)}})
    )
    assert halted.halt is not None and halted.version == 1
    (only,) = halted.halt.operations
    assert only.operation == "rough-od"
    assert "measured 6000 - 10 = 5990 is past its limit 2000 by 199.5 %" in only.message
    # the same reading under halt_over 2 (200 %) is no gross breach
    lenient = start(plan, RcbSettings(strategy=strategy, halt_over=2.0))
    kept, _ = update(
        lenient, PartReport("G-2", 1, {"rough-od": {"force_N": Measurement(6000.0, 10)}})
    )
    assert kept.halt is None or "halt_over" not in kept.halt.message


def test_a_models_exponent_stderr_is_the_priors_spread(plan):
    # A fitted model carries its exponents' standard errors (rcb fit prints and writes them);
    # the learn prior takes them instead of the default 15 % of each exponent.
    op = plan.operations[0]
    model = plan.tools[op.tool].models["force_N"]
    fitted = replace(model, exponent_stderr={"feed_mm_rev": 0.021})
    belief = post.prior(fitted, op, coverage_k=2.0, exponent_sd=0.15)
    i = 1 + belief.names.index("feed_mm_rev")
    assert_allclose(math.sqrt(belief.cov[i][i]), 0.021)
    j = 1 + belief.names.index("depth_mm")
    assert_allclose(math.sqrt(belief.cov[j][j]), 0.15 * abs(model.exponents["depth_mm"]))


@pytest.mark.parametrize(
    ("stderr", "field"),
    [
        ({"feed_mm_rev": -0.1}, "tools.models.force_N.exponent_stderr.feed_mm_rev"),
        ({"diameter": 0.1}, "tools.models.force_N.exponent_stderr.diameter"),
    ],
)
def test_bad_exponent_stderr_is_refused_naming_the_field(stderr, field):
    from models.errors import InputError
    from models.tool import model_from_mapping

    data = {"K": 2130, "dK": 150, "exponents": {"feed_mm_rev": 0.78}, "exponent_stderr": stderr}
    with pytest.raises(InputError) as err:
        model_from_mapping("force_N", data, "turning", "tools.models.force_N")
    assert err.value.field == field
    good = {**data, "exponent_stderr": {"feed_mm_rev": 0.02}}
    assert model_from_mapping("force_N", good, "turning", "").exponent_stderr == {
        "feed_mm_rev": 0.02
    }


def test_a_kept_clarabel_solver_answers_as_a_new_one(plan):
    # supervisor.optimize.socp keeps one solver per program structure and thread and updates its
    # data: the optimum must be the one a solver built for the program alone gives.
    import threading

    machine = _scaled_machine(plan, 1.0)
    rng = np.random.default_rng(5)
    state = start(plan, RcbSettings(strategy="learn"))
    lps = []
    for k in range(4):
        setpoints = {op.name: op.setpoint for op in state.setpoints.operations}
        outcome = run_part(machine, setpoints, rng)
        state, _ = update(state, PartReport(f"K-{k}", state.version, outcome.measurements))
        cones = learned_cones(state)
        for op in plan.operations:
            if op.name in cones:
                lps.append(formulate(op, state.tools[op.name], plan.machine, cones[op.name]))
    updated = [socp.maximize(lp) for lp in lps]  # one thread: later ones are data updates
    for lp, (status, x) in zip(lps, updated, strict=True):
        fresh: list[object] = []
        worker = threading.Thread(target=lambda lp=lp, out=fresh: out.append(socp.maximize(lp)))
        worker.start()
        worker.join()  # a new thread: a new solver, built for this program
        (status_new, x_new) = fresh[0]
        assert status == status_new == "optimal"
        # exactly: an answer must not depend on what the solver solved before (reproducible
        # certificates for any number of worker processes)
        assert_array_equal(x, x_new)
