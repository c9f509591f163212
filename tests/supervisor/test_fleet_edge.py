"""The fleet prior carries the edge's rise over its life (issue 32), learned by other
machines, and beside the catalogue band it keeps the band's rule: vetoed by a mean, not a cone.

Numbers from :mod:`supervisor.fleet.evidence` (``ω = n_max w``) and
:func:`supervisor.optimize.optimizer._agrees`.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest

from supervisor.fleet.hierarchy import DEFAULT_EDGE_SPREAD
from supervisor.fleet.learned import Learned
from supervisor.fleet.prior import fleet_priors
from supervisor.inputs.part_report import Measurement
from supervisor.inputs.plan import load_plan
from supervisor.rcb import posterior as post
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start

PLAN = load_plan(Path(__file__).resolve().parents[2] / "examples" / "ivester_demo_part.toml")
SETTINGS = RcbSettings(strategy="learn")
ROUGH_OD = next(o for o in PLAN.operations if o.name == "rough-od")
#: rough-od's edge makes 10 parts (parts_per_edge = 10): ages 0 … 9, n_max = 9
N_MAX = 9


def _catalogue(quantity: str) -> post.Posterior:
    model = PLAN.tools[ROUGH_OD.tool].models[quantity]
    return post.prior(model, ROUGH_OD, SETTINGS.coverage_k, SETTINGS.exponent_sd, SETTINGS.edge_sd)


def _wearing(machine: str, rise: float, edges: int = 3) -> Learned:
    """rough-od's force on ``machine`` after ``edges`` edges' lives of readings that rise by
    ``rise`` (ln) from a new edge to its last part, at the catalogue's value on a new edge, at
    the corners of the half-size box in turn, ``u`` 2 %."""
    belief = prior = _catalogue("force_N")
    half = [0.25 * math.log(ROUGH_OD.bounds[n][1] / ROUGH_OD.bounds[n][0]) for n in prior.names]
    for i in range(edges * (N_MAX + 1)):
        age = i % (N_MAX + 1)
        signs = [1 if (i >> j) & 1 else -1 for j in range(len(half))]
        ln_x = [c + s * h for c, s, h in zip(prior.center, signs, half, strict=True)]
        point = {n: math.exp(v) for n, v in zip(prior.names, ln_x, strict=True)}
        y = math.exp(float(prior.features(point) @ prior.mean_array) + rise * age / N_MAX)
        belief = post.observe(belief, point, Measurement(y, 0.02 * y), 2.0, 0.0, age)
    tool = PLAN.tools[ROUGH_OD.tool]
    return Learned(machine, f"plan on {machine}", ROUGH_OD, tool, belief, 2.0, SETTINGS.exponent_sd)


def test_the_edge_rise_two_machines_learned_is_a_new_machines_prior() -> None:
    """Two machines whose force rises 8 % over an edge's life: a new machine's prior for the
    edge-age coefficient is ``0.08 / 9`` per part, not the catalogue's ``0 ± 0.1 / 9``."""
    learned = [_wearing("m1", 0.08), _wearing("m2", 0.08)]
    made = fleet_priors(PLAN, learned, 2.0, SETTINGS.exponent_sd)[("rough-od", "force_N")]
    catalogue = _catalogue("force_N")
    w, w_var = made.posterior.mean[-1], made.posterior.cov[-1][-1]
    assert catalogue.mean[-1] == 0.0
    assert catalogue.cov[-1][-1] == pytest.approx((0.1 / N_MAX) ** 2)
    assert w * N_MAX == pytest.approx(0.08, abs=0.01)
    assert w_var < 0.05 * catalogue.cov[-1][-1]
    # however many edges the fleet saw, a new machine's own rise may differ by sigma_omega
    assert w_var > (DEFAULT_EDGE_SPREAD / N_MAX) ** 2
    assert len(made.posterior.mean) == len(catalogue.mean)  # (ln Y(c), f, v, w)


def test_an_edge_that_does_not_wear_is_learned_as_such() -> None:
    """The same with no rise: ``w`` stays at 0 and narrows (a catalogue-wide cone at the
    edge's end would cost the new machine's speed for nothing), to the between-machine
    spread of the rise, not below (a new machine's edges may wear as the fleet's did not)."""
    learned = [_wearing("m1", 0.0), _wearing("m2", 0.0)]
    made = fleet_priors(PLAN, learned, 2.0, SETTINGS.exponent_sd)[("rough-od", "force_N")]
    assert made.posterior.mean[-1] * N_MAX == pytest.approx(0.0, abs=0.01)
    assert made.posterior.cov[-1][-1] < 0.05 * _catalogue("force_N").cov[-1][-1]
    assert made.posterior.cov[-1][-1] > (DEFAULT_EDGE_SPREAD / N_MAX) ** 2


def _fleet(shift: float, sd: float) -> post.Posterior:
    """rough-od's catalogue force belief with ``ln Y(c)`` moved by ``shift``, its sd ``sd``."""
    belief = _catalogue("force_N")
    cov = [list(row) for row in belief.cov]
    cov[0][0] = sd**2
    mean = (belief.mean[0] + shift, *belief.mean[1:])
    return replace(belief, mean=mean, cov=tuple(tuple(row) for row in cov))


def test_a_fleet_cone_wider_than_the_band_keeps_the_band_optimum() -> None:
    """A fleet that says machines differ by 5 % in rough-od's force (``z σ`` = 20 %, past
    CNMG432RN's 7 % band, Ivester & Heigel Table 2) at the catalogue's mean: the band optimum
    runs, as from the catalogue (the band is the proven fallback, vetoed by what was learned,
    not by what is uncertain: optimizer._agrees). A fleet whose mean is 10 % over the
    catalogue's puts the band optimum past the limit: the cone's optimum runs, slower."""
    catalogue = start(PLAN, SETTINGS).setpoints.operations[0]
    assert (catalogue.name, catalogue.robust_by) == ("rough-od", "band")
    wide = start(PLAN, SETTINGS, {("rough-od", "force_N"): _fleet(0.0, 0.05)})
    assert wide.setpoints.operations[0].setpoint == catalogue.setpoint
    over = start(PLAN, SETTINGS, {("rough-od", "force_N"): _fleet(math.log(1.1), 0.05)})
    vetoed = over.setpoints.operations[0]
    assert vetoed.robust_by == "cone" and vetoed.fallback == catalogue
    assert vetoed.mrr_cm3_min < 0.9 * catalogue.mrr_cm3_min
    shifted = _fleet(math.log(1.1), 0.05)
    mean = float(shifted.features(vetoed.setpoint) @ shifted.mean_array)
    assert math.exp(mean + SETTINGS.z * 0.05) <= ROUGH_OD.limits["force_N"] * (1 + 1e-6)
