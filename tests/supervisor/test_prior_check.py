"""A fleet prior its readings reject is widened (issue 32, :mod:`supervisor.rcb.prior_check`).

The Bayes factor is checked against the closed form of a one-parameter model; the learner
against a virtual machine outside the spread its prior believes in (where the fleet prior,
unwidened, crossed a roughness limit for parts on end) and one inside it (never widened).
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from api.rest.schemas.parts import parse_report
from models.errors import InputError
from supervisor.fleet.document import item_json, read_item
from supervisor.fleet.learned import Learned
from supervisor.inputs.part_report import Measurement
from supervisor.inputs.plan import load_plan
from supervisor.rcb import posterior as post
from supervisor.rcb.information_form import positive_part
from supervisor.rcb.learning import as_started, belief_of, discount
from supervisor.rcb.prior_check import OUTLIER_PROBABILITY, log_bayes_factor, rebased
from supervisor.rcb.replan import replan
from supervisor.rcb.state import RcbSettings, RcbState
from supervisor.rcb.update import start, update
from supervisor.virtual.certificate import ScenarioTrace
from supervisor.virtual.fault_spec import parse_faults
from supervisor.virtual.fleet import (
    DEFAULT_MACHINE_SPREAD,
    fleet_truths,
    known_priors,
    machines_of,
)
from supervisor.virtual.fleet_scenario import FleetWorld, new_machine_starts
from supervisor.virtual.scenario import run_machine
from supervisor.virtual.simulate import run_part

PLAN_FILE = Path(__file__).resolve().parents[2] / "examples" / "ivester_demo_part.toml"
PLAN = load_plan(PLAN_FILE)
SETTINGS = RcbSettings(strategy="learn")


def _intercept(mean: float, variance: float) -> post.Posterior:
    """A law with only ``ln Y``: ``ln y = β₀ + ε``."""
    return post.Posterior("force_N", (), (), {}, (mean,), ((variance,),))


def _normal_log_pdf(x: float, variance: float) -> float:
    return -0.5 * (math.log(2 * math.pi * variance) + x * x / variance)


@given(
    st.floats(-0.5, 0.5),
    st.floats(1e-4, 1e-2),
    st.floats(1e-3, 0.1),
    st.floats(1e-5, 1e-3),
)
@settings(max_examples=60, deadline=None)
def test_the_bayes_factor_is_the_ratio_of_the_two_predictive_densities(
    reading: float, prior_var: float, widening: float, noise_var: float
) -> None:
    """One reading ``z`` of ``β₀ ~ N(0, s²)``: ``B = N(z; 0, s² + v + σ²) / N(z; 0, s² + σ²)``
    (the evidence of a normal mean with known variance, Gelman et al. §2.5)."""
    prior = _intercept(0.0, prior_var)
    y = math.exp(reading)
    u = 2.0 * math.sqrt(noise_var) * y  # k = 2, relative σ = √noise_var
    after = post.observe(prior, {}, Measurement(y, u), 2.0, 0.0)
    factor = log_bayes_factor(prior, after, widening)
    wide = _normal_log_pdf(reading, prior_var + widening + noise_var)
    fleet = _normal_log_pdf(reading, prior_var + noise_var)
    assert factor == pytest.approx(wide - fleet, rel=1e-6, abs=1e-8)


def test_what_a_change_discounted_is_not_evidence_for_the_factor() -> None:
    """A fleet prior 2 % wide (precision 2500), a reading of 1 % noise (10 000) 4 σ off, then a
    change's discount of 1e-3: the belief's precision, 1/(8e-5 + 1e-3) = 926, is under the
    prior's, so nothing the reading showed is left as evidence (by hand) and ``B = 1``. The
    unprojected difference, −1574, made the widened law's "posterior" precision 96 − 1574
    negative: no factor at all, and such a plan was never checked again."""
    prior = _intercept(0.0, 0.02**2)
    y = math.exp(4.0 * math.hypot(0.02, 0.01))
    after = post.observe(prior, {}, Measurement(y, 2 * 0.01 * y), 2.0, 0.0)
    assert after.cov[0][0] == pytest.approx(8e-5)
    assert log_bayes_factor(prior, discount(after, 1e-3), 0.1**2) == pytest.approx(0.0, abs=1e-12)
    # a smaller discount leaves part of the reading: the factor is that part's, still past 19
    kept = discount(after, 1e-4)  # precision 1/1.8e-4 = 5556: 3056 of the reading's 10 000
    found = log_bayes_factor(prior, kept, 0.1**2)
    assert found is not None and found > math.log(19)


def test_a_reading_far_from_the_fleet_widens_and_one_near_it_does_not() -> None:
    """A fleet prior 2 % wide, the widening 10 %, the reading's noise 1 %: the predictive
    variances are 5e-4 and 1.05e-2, so a reading ``k`` predictive σ off gives
    ``ln B = ½ ln(5e-4/1.05e-2) + ½ k² 5e-4 (1/5e-4 − 1/1.05e-2) = −1.522 + 0.4762 k²``
    (by hand): 0.383 at 2σ (the fleet's holds), and past the odds 19 of
    :data:`OUTLIER_PROBABILITY` from ``k = 3.06`` on, on either side."""
    prior, widening, noise = _intercept(0.0, 0.02**2), 0.1**2, 0.01
    odds = math.log((1 - OUTLIER_PROBABILITY) / OUTLIER_PROBABILITY)
    sd = math.hypot(0.02, noise)

    def factor(sigmas: float) -> float:
        y = math.exp(sigmas * sd)
        after = post.observe(prior, {}, Measurement(y, 2 * noise * y), 2.0, 0.0)
        found = log_bayes_factor(prior, after, widening)
        assert found is not None
        return found

    assert odds == pytest.approx(math.log(19))
    assert factor(2.0) == pytest.approx(0.3825, abs=1e-3)
    assert factor(3.0) < odds < factor(3.1)
    assert factor(-3.1) == pytest.approx(factor(3.1))  # a machine below the fleet too


def test_rebased_keeps_the_readings_and_lets_the_intercept_go() -> None:
    """Readings learned on the fleet prior, moved onto the widened one, give the posterior a
    learner started on the widened one would have: the same precision from the readings."""
    prior, widening = _intercept(0.0, 0.02**2), 0.1**2
    readings = [Measurement(1.2, 0.024), Measurement(1.21, 0.0242)]
    on_fleet, on_wide = prior, _intercept(0.0, 0.02**2 + widening)
    for m in readings:
        on_fleet = post.observe(on_fleet, {}, m, 2.0, 0.0)
        on_wide = post.observe(on_wide, {}, m, 2.0, 0.0)
    moved = rebased(on_fleet, prior, widening)
    assert moved.mean[0] == pytest.approx(on_wide.mean[0], rel=1e-9)
    assert moved.cov[0][0] == pytest.approx(on_wide.cov[0][0], rel=1e-9)
    assert moved.prior_widening == widening
    assert post.from_json(moved.to_json()) == moved  # it is stored with the belief


def test_a_belief_a_change_discounted_below_its_start_widens_as_it_is() -> None:
    """After a change's discount the belief holds less precision than the fleet prior it
    started from (``1/(4.4e-5 + 0.05²) < 1/0.02²``): its readings can no longer be read off
    it, so its own ``ln K`` is widened, mean kept (until 2026-12-06 the widened start stood,
    ``N(0, 0.02² + 0.1²)``, the readings' 1.2 thrown away; before that, an extrapolation of
    the two, the next tests)."""
    prior, widening = _intercept(0.0, 0.02**2), 0.1**2
    before = prior
    for m in (Measurement(1.2, 0.024), Measurement(1.21, 0.0242)):
        before = post.observe(before, {}, m, 2.0, 0.0)
    before = discount(before, 0.05**2)
    assert before.cov[0][0] > prior.cov[0][0]
    moved = rebased(before, prior, widening)
    assert moved.mean[0] == pytest.approx(before.mean[0], rel=1e-12)
    assert moved.mean[0] == pytest.approx(math.log(1.2), abs=0.02)
    assert moved.cov[0][0] == pytest.approx(before.cov[0][0] + widening, rel=1e-12)
    assert moved.prior_widening == widening


#: Seed 49's finish-od roughness belief (depth, feed, speed exponents) at part 6's report,
#: where the fleet prior was let go: the start (the fleet's) and the belief after 5 readings
#: and a change's discount (``closed_loop.py --fleet 4 --fleet-fault noise-scale:3``).
_CENTER = (-0.8047189562170501, -2.0998525389399636, 4.926097129074289)
_START_49 = (
    (0.665945, -0.086295, 1.096652, -0.002),
    (
        (0.00136616, -0.000134104, -0.00110786, -2.89246e-08),
        (-0.000134104, 0.000168882, -3.65776e-06, -1.04865e-10),
        (-0.00110786, -3.65776e-06, 0.00483428, -7.88934e-10),
        (-2.89246e-08, -1.04865e-10, -7.88934e-10, 9.16e-08),
    ),
)
_BEFORE_49 = (
    (0.751729, -0.086243, 1.082806, -0.002),
    (
        (0.00131278, -0.000135408, -0.00052212, -2.92057e-08),
        (-0.000135408, 0.000168881, -3.40784e-06, -1.0502e-10),
        (-0.00052212, -3.40784e-06, 0.00469598, -7.35029e-10),
        (-2.92057e-08, -1.0502e-10, -7.35029e-10, 9.16e-08),
    ),
)


def test_a_discounted_belief_widened_keeps_its_exponent() -> None:
    """Seed 49 (above): rebased on the widened start with the positive part of ``P − P₀``,
    whose eigenvectors mix the discount's loss with the readings, the feed exponent went from
    1.083 to 0.971 (and on to 0.62; the truth 1.14) and the roughness limit was crossed at
    parts 18-19. Widened as it is, every exponent is the belief's and only ``ln K`` grows."""
    names = ("depth_mm", "feed_mm_rev", "speed_m_min")
    start, before = (
        post.Posterior("roughness_um", names, _CENTER, {}, mean, cov)
        for mean, cov in (_START_49, _BEFORE_49)
    )
    variance = 0.03628117913832199  # the catalogue prior's ln K variance (finish-od's insert)
    moved = rebased(before, start, variance)
    assert moved.mean == before.mean
    assert moved.cov[0][0] == pytest.approx(before.cov[0][0] + variance, rel=1e-12)
    assert [row[1:] for row in moved.cov[1:]] == [row[1:] for row in before.cov[1:]]
    # what the positive part made of it: a feed exponent no reading gave
    j, h = positive_part(
        before.precision - start.precision,
        before.precision @ before.mean_array - start.precision @ start.mean_array,
    )
    wide = discount(start, variance)
    old = np.linalg.solve(wide.precision + j, wide.precision @ wide.mean_array + h)
    assert old[2] == pytest.approx(0.971, abs=0.002)


def test_a_machine_outside_a_noisy_fleet_crosses_no_limit_after_its_first_part() -> None:
    """Seed 49 of ``closed_loop.py --fleet 4 --fleet-fault noise-scale:3`` (the learning
    machines' chains 3 x noisier than they say; the new machine outside the spread, clean):
    finish-od's roughness crossed at parts 18 and 19 on the code before, none now."""
    world = FleetWorld(fleet_faults=parse_faults(["noise-scale:3"]))
    s = new_machine_starts(PLAN, 49, 4, 30, world)
    assert s.outside
    trace, _ = run_machine(s.from_fleet, s.machine, 49, 20, noise_seed=s.noise)
    assert [w for w in trace.where if w[0] > 1] == []


def test_a_known_prior_on_a_curved_truth_keeps_its_belief_finite() -> None:
    """``closed_loop.py --fleet 4 --fault curvature``, seed 139: the known prior's belief of
    finish-grooves' roughness, discounted by a change at part 8 and let go in the same
    report, was rebased to ``ln Ra`` 4.4 (from 0.87) and its ``K`` overflowed a float at part
    12 (``OverflowError`` out of the optimiser). It now makes its 12 parts, every belief's
    intercept within 1 (in ln) of where it stood at the start."""
    seed = 139
    truths = fleet_truths(PLAN, seed, DEFAULT_MACHINE_SPREAD)
    machine = machines_of(
        PLAN, truths, seed, 4, machine_spread=DEFAULT_MACHINE_SPREAD, outside=True
    )[-1]
    known = start(PLAN, SETTINGS, known_priors(PLAN, truths, DEFAULT_MACHINE_SPREAD, SETTINGS))
    faults = parse_faults(["curvature"])
    trace, state = run_machine(known, machine, seed, 12, faults=faults, noise_seed=[seed, 3])
    assert trace.parts_made == 12
    for key, belief in state.posterior.items():
        assert abs(belief.mean[0] - known.posterior[key].mean[0]) < 1.0, key


def _run(outside: bool, believed_spread: float, parts: int) -> tuple[ScenarioTrace, RcbState]:
    """A new machine (6 % spread, ``outside``: at 3 spreads) from the prior of a controller
    that knows the fleet's law and believes its spread is ``believed_spread``."""
    seed = 59
    truths = fleet_truths(PLAN, seed, 0.06)
    machine = machines_of(PLAN, truths, seed, 1, machine_spread=0.06, outside=outside)[-1]
    priors = known_priors(PLAN, truths, believed_spread, SETTINGS)
    return run_machine(start(PLAN, SETTINGS, priors), machine, seed, parts)


def test_a_machine_outside_the_believed_spread_crosses_no_limit_after_its_first_part() -> None:
    """18 % from the fleet where its prior believes 4 %: before the check, finish-grooves'
    and finish-contour's roughness crossed at parts 2-4 (the innovation taught the chain a
    noise scale that froze the belief); now only the first part crosses, and the belief
    carries the widening, the catalogue's ln K variance."""
    trace, state = _run(outside=True, believed_spread=0.04, parts=8)
    assert all(part == 1 for part, _, _ in trace.where), trace.where
    assert trace.where  # the first part: no controller knows the machine before it
    widened = {k: b.prior_widening for k, b in state.posterior.items() if b.prior_widening > 0}
    for name in ("finish-grooves", "finish-contour"):
        op = next(o for o in PLAN.operations if o.name == name)
        model = PLAN.tools[op.tool].models["roughness_um"]
        variance = ((model.dK / model.K) / SETTINGS.coverage_k) ** 2
        assert widened[(name, "roughness_um")] == pytest.approx(variance)
        assert belief_of(state, op, "roughness_um").observations == 8


def test_a_machine_inside_the_spread_keeps_its_fleet_prior() -> None:
    """The same fleet with a machine inside the spread its prior believes: nothing widens."""
    _, state = _run(outside=False, believed_spread=0.06, parts=10)
    assert state.posterior  # every (operation, quantity) learned
    assert all(b.prior_widening == 0 for b in state.posterior.values())


@pytest.mark.parametrize(
    ("field", "value", "says"),
    [("prior_widening", -0.01, "must be a number >= 0"), ("noise_scale2", 0.0, "> 0")],
)
def test_an_imported_posterior_with_an_impossible_widening_is_refused(
    field: str, value: float, says: str
) -> None:
    """``rcb models import`` reads a plan's belief with its widening: a negative one would
    make a prior variance negative, a noise scale of 0 readings of infinite weight."""
    op = next(o for o in PLAN.operations if o.name == "finish-od")
    tool = PLAN.tools[op.tool]
    belief = post.prior(tool.models["roughness_um"], op, 2.0, SETTINGS.exponent_sd)
    item = Learned("m1", "p1", op, tool, belief, 2.0, SETTINGS.exponent_sd)
    data = item_json(item)
    data["posterior"][field] = value
    with pytest.raises(InputError) as raised:
        read_item(data, "document.learned[0]")
    assert raised.value.field == f"document.learned[0].posterior.{field}"
    assert says in str(raised.value)
    assert read_item(item_json(item), "document.learned[0]").posterior == belief


def test_a_glitch_far_below_the_fleet_is_quarantined_and_does_not_let_it_go() -> None:
    """A roughness reading at a tenth of what the machine makes (an air cut) is the monitor's
    to quarantine, not evidence that the machine is unlike the fleet: every prior holds; a
    reading at 0.8 x (a machine better than the fleet) lets it go."""
    seed = 59
    truths = fleet_truths(PLAN, seed, 0.06)
    machine = machines_of(PLAN, truths, seed, 1, machine_spread=0.06)[-1]
    initial = start(PLAN, SETTINGS, known_priors(PLAN, truths, 0.04, SETTINGS))
    setpoints = {op.name: op.setpoint for op in initial.setpoints.operations}
    outcome = run_part(machine, setpoints, np.random.default_rng(seed))

    def reported(factor: float) -> RcbState:
        operations = [
            {
                "name": op,
                "measurements": {
                    q: {
                        "value": m.value * (factor if q == "roughness_um" else 1.0),
                        "uncertainty": m.uncertainty * (factor if q == "roughness_um" else 1.0),
                    }
                    for q, m in measured.items()
                },
            }
            for op, measured in outcome.measurements.items()
        ]
        body = {"serial": "p-1", "setpoint_version": 1, "operations": operations}
        state, decisions = update(initial, parse_report(body))
        notes = {d.note for d in decisions if d.quantity == "roughness_um"}
        assert (notes == {"implausible_low"}) == (factor < 0.5), notes
        said = "the fleet prior does not hold on this machine (Bayes factor "
        saying = {(d.operation, d.quantity) for d in decisions if said in d.reason}
        assert saying == {k for k, b in state.posterior.items() if b.prior_widening > 0}
        return state

    glitch, lower = reported(0.1), reported(0.8)
    assert all(b.prior_widening == 0 for b in glitch.posterior.values())
    assert {q for (_, q), b in lower.posterior.items() if b.prior_widening > 0} == {"roughness_um"}


def test_a_reset_of_the_bands_keeps_a_prior_that_was_let_go_let_go() -> None:
    """An engineer's ``reset_bands`` forgets what the plan learned, not that the machine lies
    outside the fleet: ``learn`` goes back to its start, widened where it was let go, and the
    check does not judge it again. (A start from the fleet's prior unwidened crossed
    finish-grooves' and finish-contour's roughness at the next part, seeds 60-65.)"""
    _, state = _run(outside=True, believed_spread=0.04, parts=3)
    widened = {k: b.prior_widening for k, b in state.posterior.items() if b.prior_widening > 0}
    assert widened
    body = tomllib.loads(PLAN_FILE.read_text(encoding="utf-8"))
    again = replan(state, body, {"reset_bands": True}).state
    assert {k: b.prior_widening for k, b in again.posterior.items() if b.prior_widening} == widened
    operations = {op.name: op for op in PLAN.operations}
    for (name, quantity), belief in again.posterior.items():
        assert belief.observations == 0  # what was learned is forgotten
        assert again.priors[(name, quantity)] == belief  # the start, as a stored plan loads it
        assert belief_of(again, operations[name], quantity) == belief
        assert as_started(again.priors[(name, quantity)], belief) == belief  # not widened twice
    truths = fleet_truths(PLAN, 59, 0.06)
    machine = machines_of(PLAN, truths, 59, 1, machine_spread=0.06, outside=True)[-1]
    for seed in (60, 63):
        after, ended = run_machine(again, machine, seed, 4)
        assert after.where == (), after.where
        assert {k: b.prior_widening for k, b in ended.posterior.items() if b.prior_widening} == (
            widened
        )
