"""A fleet whose machines differ by more than the catalogue's band vetoes the band's optimum.

The optimiser runs the faster of the band's and the cone's optimum, the band vetoed by the
learned mean only (:func:`supervisor.optimize.optimizer._agrees`). Where the fleet's machines,
by their own readings, differ by more than the band's ``dK/K`` (at least two machines; 2 sd of
the spread's 95 % lower credible bound past it), a new machine may well lie outside the band:
the fleet prior's cones then veto it at 2 sd (:func:`supervisor.fleet.prior._beyond_band`;
docs/benchmarks.md, "The band's veto").
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest
from scipy.stats import chi2

from supervisor.fleet.learned import Learned
from supervisor.fleet.prior import fleet_priors
from supervisor.fleet.provenance import FLEET_VETO_Z
from supervisor.fleet.spread import lower_bound
from supervisor.inputs.part_report import Measurement
from supervisor.inputs.plan import load_plan
from supervisor.rcb import posterior as post
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start

PLAN = load_plan(Path(__file__).resolve().parents[2] / "examples" / "ivester_demo_part.toml")
SETTINGS = RcbSettings(strategy="learn")
ROUGH_OD = next(o for o in PLAN.operations if o.name == "rough-od")
KEY = ("rough-od", "force_N")
#: CNMG432RN's force band, dK/K (Ivester & Heigel Table 2, the demo's catalogue).
BAND = (
    PLAN.tools[ROUGH_OD.tool].models["force_N"].dK / PLAN.tools[ROUGH_OD.tool].models["force_N"].K
)


def _catalogue() -> post.Posterior:
    model = PLAN.tools[ROUGH_OD.tool].models["force_N"]
    return post.prior(model, ROUGH_OD, SETTINGS.coverage_k, SETTINGS.exponent_sd, SETTINGS.edge_sd)


def _machine(name: str, offset: float, parts: int = 30) -> Learned:
    """rough-od's force on ``name``: ``parts`` readings at ``exp(offset)`` times the catalogue's
    mean, at the corners of the half-size box in turn, on new edges, ``u`` 2 %."""
    belief = prior = _catalogue()
    half = [0.25 * math.log(ROUGH_OD.bounds[n][1] / ROUGH_OD.bounds[n][0]) for n in prior.names]
    for i in range(parts):
        signs = [1 if (i >> j) & 1 else -1 for j in range(len(half))]
        ln_x = [c + s * h for c, s, h in zip(prior.center, signs, half, strict=True)]
        point = {n: math.exp(v) for n, v in zip(prior.names, ln_x, strict=True)}
        y = math.exp(float(prior.features(point) @ prior.mean_array) + offset)
        belief = post.observe(belief, point, Measurement(y, 0.02 * y), 2.0, 0.0, 0)
    tool = PLAN.tools[ROUGH_OD.tool]
    return Learned(name, f"plan on {name}", ROUGH_OD, tool, belief, 2.0, SETTINGS.exponent_sd)


def _veto(offsets: list[float]) -> float:
    """The fleet prior's ``band_veto_z`` from machines at ``offsets``; its provenance line says
    so where it vetoes, and only there."""
    learned = [_machine(f"m{i}", o) for i, o in enumerate(offsets)]
    made = fleet_priors(PLAN, learned, 2.0, SETTINGS.exponent_sd)[KEY]
    said = "; machines differ by more than the catalogue band: checked at 2 sd"
    assert made.provenance.describe().endswith(said) == (made.posterior.band_veto_z > 0)
    return made.posterior.band_veto_z


def test_machines_further_apart_than_the_band_veto_it_and_close_ones_do_not() -> None:
    """Three machines at -20 %, 0, +20 % (sd 0.2 in ln K, past the 7 % band): the prior
    vetoes at 2 sd. At -1 %, 0, +1 %: at the mean, as the catalogue start."""
    assert BAND == pytest.approx(0.07, abs=0.005)
    assert _veto([-0.2, 0.0, 0.2]) == FLEET_VETO_Z == 2.0
    assert _veto([-0.01, 0.0, 0.01]) == 0.0


def test_a_spread_under_the_band_vetoes_where_it_credibly_leaves_machines_outside() -> None:
    """Three machines at -8 %, 0, +8 %: ``σ_b`` 6.5 %, under the 7 % band, but at 95 % it is
    above 4.2 % (4 degrees of freedom, the default's 2 with the machines' 2), and 2 sd of
    that is past the band: more than one new machine in 20 outside it. Two machines 6 % apart
    (4.6 %, 3 degrees of freedom): 2 x 2.9 % is not, and the band runs."""
    assert _veto([-0.08, 0.0, 0.08]) == FLEET_VETO_Z
    assert _veto([-0.03, 0.03]) == 0.0


def test_a_halted_plan_of_the_tool_checks_the_band_at_2_sd() -> None:
    """Machines 1 % apart check the band at the mean; where a plan of their tool halted
    (its readings left out), at 2 sd: the spread read from the rest is the lower for it.
    Another tool's halt changes nothing."""
    learned = [_machine(f"m{i}", o) for i, o in enumerate([-0.01, 0.0, 0.01])]
    tool = ROUGH_OD.tool
    for halted, veto in (((), 0.0), ((tool,), FLEET_VETO_Z), (("ANOTHER",), 0.0)):
        made = fleet_priors(PLAN, learned, 2.0, SETTINGS.exponent_sd, halted=halted)[KEY]
        assert made.posterior.band_veto_z == veto, halted
        assert made.provenance.band_checked_at_sd == (veto or None), halted
        # it says why: the halt, not a spread these machines do not have
        assert made.provenance.band_checked_why == (("halted",) if veto else ()), halted
        said = "; a plan of its tool halted: checked at 2 sd"
        assert made.provenance.describe().endswith(said) == bool(veto), halted
        assert "differ by more" not in made.provenance.describe()
    # machines 20 % apart whose tool also halted: both reasons
    far = [_machine(f"m{i}", o) for i, o in enumerate([-0.2, 0.0, 0.2])]
    both = fleet_priors(PLAN, far, 2.0, SETTINGS.exponent_sd, halted=(tool,))[KEY].provenance
    assert both.band_checked_why == ("spread", "halted")
    assert both.describe().endswith(
        "; machines differ by more than the catalogue band and a plan of its tool halted: "
        "checked at 2 sd"
    )


def test_the_lower_bound_is_the_scaled_inverse_chi2_quantile() -> None:
    """``σ √(ν/χ²_{0.95,ν})`` with the χ² table's 95 % points (7.815 at 3 degrees of freedom,
    9.488 at 4; any statistics text's table), and scipy's for any ``ν``."""
    assert lower_bound(1.0, 3.0) == pytest.approx(math.sqrt(3 / 7.815), rel=1e-4)
    assert lower_bound(0.05, 4.0) == pytest.approx(0.05 * math.sqrt(4 / 9.488), rel=1e-4)
    for nu in (1.0, 2.5, 30.0):
        assert lower_bound(0.1, nu, 0.9) == pytest.approx(0.1 * math.sqrt(nu / chi2.ppf(0.9, nu)))
    # under 1 degree of freedom no bound (at 0.01 the formula gave 16 x the spread; at 0, 0/0)
    assert lower_bound(0.05, 0.0) == lower_bound(0.05, 0.01) == 0.0


def test_one_machine_is_no_evidence_against_the_band() -> None:
    """One machine, however far from the catalogue: no between-machine estimate (its spread
    is the default, an assumption), so no veto; two machines 30 % apart are evidence."""
    assert _veto([0.3]) == 0.0
    assert _veto([-0.15, 0.15]) == FLEET_VETO_Z


def _fleet(sd: float, veto_z: float) -> post.Posterior:
    """rough-od's catalogue force belief with its ``ln Y(c)`` sd ``sd``, vetoing at ``veto_z``."""
    belief = _catalogue()
    cov = [list(row) for row in belief.cov]
    cov[0][0] = sd**2
    return replace(belief, cov=tuple(tuple(row) for row in cov), band_veto_z=veto_z)


def test_a_vetoing_prior_runs_its_cone_where_the_band_optimum_is_past_2_sd() -> None:
    """A fleet at the catalogue's mean whose machines differ by 5 % (2 sd = 10 %, past the 7 %
    band): without the veto the band optimum runs, as from the catalogue; with it the cone's
    optimum runs, slower, and holds the force limit at z = 4 (the plan's)."""
    catalogue = start(PLAN, SETTINGS).setpoints.operations[0]
    kept = start(PLAN, SETTINGS, {KEY: _fleet(0.05, 0.0)}).setpoints.operations[0]
    assert kept.setpoint == catalogue.setpoint
    vetoed = start(PLAN, SETTINGS, {KEY: _fleet(0.05, FLEET_VETO_Z)}).setpoints.operations[0]
    assert vetoed.robust_by == "cone" and vetoed.fallback == catalogue
    assert vetoed.mrr_cm3_min < catalogue.mrr_cm3_min
    belief = _fleet(0.05, FLEET_VETO_Z)
    mean = float(belief.features(vetoed.setpoint) @ belief.mean_array)
    assert math.exp(mean + SETTINGS.z * 0.05) <= ROUGH_OD.limits["force_N"] * (1 + 1e-6)


def test_the_veto_is_stored_with_the_prior_and_not_carried_by_an_update() -> None:
    """``plans.prior`` holds the posterior's JSON: the veto round-trips; a reading's update
    is the plan's own belief, which vetoes by its start prior (learning.cones), not itself."""
    belief = _fleet(0.05, FLEET_VETO_Z)
    assert post.from_json(belief.to_json()) == belief
    assert "band_veto_z" not in _catalogue().to_json()
    point = {n: math.exp(c) for n, c in zip(belief.names, belief.center, strict=True)}
    after = post.observe(belief, point, Measurement(1000.0, 20.0), 2.0, 0.0, 0)
    assert after.band_veto_z == 0.0
