"""``learn``'s raise after a flagged reading is held with its own uncertainty.

The raise (:func:`supervisor.rcb.learning._at_least`) moves the intercept up to a reading the
update left under its mean. Held at the readings' full weight, it reads as if every earlier
reading had been that much higher; the next readings, at a setpoint the raise itself moved,
then teach a feed exponent the truth does not have (docs/benchmarks.md, *A year of parts*:
seed 6 of ``step:500:1.12``, finish-grooves' roughness, 1.07 learned as 1.44).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from models.powerlaw import PowerLawModel
from supervisor.inputs.part_report import Measurement
from supervisor.inputs.plan import load_plan
from supervisor.rcb import learning
from supervisor.rcb import posterior as post

from conftest import DEMO_PLAN

#: The feed finish-grooves settles at on seed 6 of the closed-loop benchmark [mm/rev].
SETTLED_FEED = 0.059
#: The truth's feed exponent there (the least squares of its own 499 readings: 1.074).
TRUE_FEED_EXPONENT = 1.07


@pytest.fixture(scope="module")
def finish_grooves():
    plan = load_plan(DEMO_PLAN)
    op = next(o for o in plan.operations if o.name == "finish-grooves")
    model = plan.tools[op.tool].models["roughness_um"]
    exponents = {**model.exponents, "feed_mm_rev": TRUE_FEED_EXPONENT}
    truth = PowerLawModel("roughness_um", model.K * 0.95, 0.0, exponents)
    return op, model, truth


def _point(op, belief, feed):
    centre = {n: math.exp(c) for n, c in zip(belief.names, belief.center, strict=True)}
    return {**op.context, **centre, "feed_mm_rev": feed}


def _settled(op, model, truth, rng):
    """300 readings (2.5 % noise, u 5 %) at the settled feed +- 0.4 %, as a settled plan's."""
    belief = post.prior(model, op, 2.0, 0.15)
    for i in range(300):
        point = _point(op, belief, SETTLED_FEED * (1 + 0.004 * (-1) ** i))
        y = truth.predict(point).value * math.exp(rng.normal(0.0, 0.025))
        belief = post.observe(belief, point, Measurement(y, 0.05 * y), 2.0, 0.0)
    return belief


def test_a_raise_lifts_the_mean_to_the_reading_and_widens_the_intercept_by_itself(
    finish_grooves,
):
    op, model, truth = finish_grooves
    belief = _settled(op, model, truth, np.random.default_rng(1))
    point = _point(op, belief, SETTLED_FEED)
    y = truth.predict(point).value * 1.08
    reading = Measurement(y, 0.05 * y)
    raised = learning._at_least(belief, point, reading, None)
    deficit = raised.mean[0] - belief.mean[0]
    at = belief.features(point)
    # the mean at the setpoint is the reading less its u, to rounding
    assert_allclose(float(at @ np.array(raised.mean)), math.log(y - reading.uncertainty))
    assert deficit > 0.02
    assert raised.mean[1:] == belief.mean[1:]
    # "raised by d, unsure by d": the intercept's variance grows by d^2, nothing else moves
    cov, before = np.array(raised.cov), np.array(belief.cov)
    assert_allclose(cov[0, 0] - before[0, 0], deficit**2, rtol=1e-9)
    cov[0, 0] = before[0, 0]
    assert_allclose(cov, before, rtol=0, atol=0)


def test_a_reading_under_the_mean_is_not_raised_to(finish_grooves):
    op, model, truth = finish_grooves
    belief = _settled(op, model, truth, np.random.default_rng(2))
    point = _point(op, belief, SETTLED_FEED)
    y = truth.predict(point).value
    assert learning._at_least(belief, point, Measurement(y, 0.05 * y), None) is belief


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_readings_after_a_raise_do_not_teach_a_false_feed_exponent(finish_grooves, seed):
    # A settled plan's reading 8 % over the truth is flagged and raised to; the raise moves
    # the setpoint 1.3 % down in feed, and 150 readings of the unchanged truth follow there.
    # Held at the readings' full weight the raise read as slope: the exponent went from
    # 1.04 to 1.71 (seed 1), 8 of its prior's standard deviations off the truth.
    op, model, truth = finish_grooves
    rng = np.random.default_rng(seed)
    belief = _settled(op, model, truth, rng)
    start = belief.mean[2]
    at_raise = _point(op, belief, SETTLED_FEED)
    y = truth.predict(at_raise).value * 1.08
    belief = learning._at_least(belief, at_raise, Measurement(y, 0.05 * y), None)
    moved = _point(op, belief, SETTLED_FEED * 0.987)
    for _ in range(150):
        y = truth.predict(moved).value * math.exp(rng.normal(0.0, 0.025))
        belief = post.observe(belief, moved, Measurement(y, 0.05 * y), 2.0, 0.0)
    assert belief.names[1] == "feed_mm_rev"
    assert abs(belief.mean[2] - start) < 0.05
    assert abs(belief.mean[2] - TRUE_FEED_EXPONENT) < 2 * math.sqrt(belief.cov[2][2])
