"""A learned model whose prior knew its law nearly exactly teaches the fleet nothing.

Its evidence ``J = P − P₀`` (:mod:`supervisor.fleet.evidence`) is a difference of precisions;
with a prior variance under :data:`~supervisor.fleet.evidence.LEAST_VARIANCE` it is round-off.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from test_fleet_prior import PLAN, SETTINGS, _catalogue, _learned

from supervisor.fleet.learned import Learned
from supervisor.fleet.prior import fleet_priors
from supervisor.inputs.part_report import Measurement
from supervisor.rcb import posterior as post


def test_a_prior_that_knows_K_to_a_ppb_teaches_nothing_and_is_not_counted() -> None:
    """A plan whose tool's force band was 1e-9 of K (dK hand-written so) learned from a prior
    of variance 2.5e-19 in ln K: its evidence ``J = P − P₀`` is the difference of precisions
    near 1e18, round-off of about 1e2 where a 2 % reading gives 2500. Made, it gave a fleet
    law of K = 1.8e-8 N and a feed exponent of −17.8 (a review, through an imported model);
    now it is not made, and the provenance counts only the machines whose evidence is in."""
    good = _learned("m2", "p2", "rough-grooves", [1.1] * 6)
    tool = PLAN.tools[good[0].operation.tool]
    force = tool.models["force_N"]
    ppb = replace(tool, models={**tool.models, "force_N": replace(force, dK=1e-9 * force.K)})
    narrow = [
        replace(item, tool=ppb, posterior=_started(item, ppb, 6))
        for item in _learned("m1", "p1", "rough-grooves", [1.1] * 6)
    ]
    made = fleet_priors(PLAN, narrow + good, 2.0, SETTINGS.exponent_sd)
    alone = fleet_priors(PLAN, good, 2.0, SETTINGS.exponent_sd)
    force_of, catalogue = made[("rough-contour", "force_N")], _catalogue("rough-contour", "force_N")
    seen = force_of.provenance
    assert (seen.plans, seen.machines, seen.readings) == (("p2",), ("m2",), 6)
    assert force_of.posterior.mean[0] == pytest.approx(catalogue.mean[0] + math.log(1.1), abs=0.03)
    sd = np.sqrt(np.diag(catalogue.cov))
    assert np.all(np.abs(np.subtract(force_of.posterior.mean, catalogue.mean))[1:] < sd[1:])
    assert ("rough-contour", "force_N") in alone
    # roughness's band was not narrowed: both machines teach it
    assert made[("rough-contour", "roughness_um")].provenance.machines == ("m1", "m2")


def _started(item: Learned, tool, readings: int) -> post.Posterior:  # type: ignore[no-untyped-def]
    """``item``'s quantity learned again from ``tool``'s prior, 10 % over the catalogue's."""
    quantity = item.posterior.quantity
    belief = post.prior(tool.models[quantity], item.operation, 2.0, SETTINGS.exponent_sd)
    centre = {n: math.exp(c) for n, c in zip(belief.names, belief.center, strict=True)}
    for _ in range(readings):
        y = 1.1 * math.exp(float(belief.features(centre) @ np.array(belief.mean)))
        belief = post.observe(belief, centre, Measurement(y, 0.02 * y), 2.0, 0.0)
    return belief
