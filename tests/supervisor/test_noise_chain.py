"""The measuring chain's noise as ``learn`` and the law count it (issue 27, "the scatter is
measured, not assumed"), with hand-computed numbers.

Three rules (supervisor.rcb.monitor, learning, update): the chain's belief learns from a drift
in progress that the alarm's own belief is gated against; the noise update takes out the
model spread at the noise as estimated, not at the prudent quantile the readings are learned
at; and once every reading of a report is in, ``learn``'s posteriors are counted at the
chain's prudent scale.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from supervisor.inputs.part_report import Measurement, PartReport
from supervisor.inputs.plan import load_plan
from supervisor.rcb import monitor as m
from supervisor.rcb import monitor_state as ms
from supervisor.rcb import noise
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start, update

from conftest import DEMO_PLAN

POINT = {"feed_mm_rev": 0.3}
EXPONENTS = {"feed_mm_rev": 0.8}
NEAR = ms.Expected(math.log(100.0), 0.05)


def _watch(monitor, y, high):
    return m.watch(monitor, NEAR, high, Measurement(y, 1.0), POINT, EXPONENTS, 0.15)


def test_a_drift_in_progress_teaches_the_chain_but_not_the_alarm():
    # ln y ~ ln 100 ± 0.01 (a model's expectation); 103 ± 1: s_n = 0.5/103, r = 2.6591, the
    # CUSUM would stand at 2.159 > 2: gated for the operation's own ŝ. The chain's belief
    # takes it at the noise share w = s_n² / (s² + s_n²) = 0.19071 and the excess
    # (e² − s²)/s_n² = (0.029559² − 1e-4)/2.3565e-5 = 32.835 (e² under the cap 16 (s² + s_n²))
    model = ms.Expected(math.log(100.0), 0.01)
    watched = _watch(ms.Monitor(), 103.0, model).monitor
    assert (watched.shape, watched.rate) == (noise.NOISE_PRIOR, noise.NOISE_RATE)
    s_n2 = (0.5 / 103) ** 2
    w = s_n2 / (1e-4 + s_n2)
    assert_allclose(w, 0.19071, rtol=1e-4)
    excess = (math.log(1.03) ** 2 - 1e-4) / s_n2
    assert_allclose(excess, 32.835, rtol=1e-4)
    assert_allclose(watched.chain_shape, 1.5 + 0.5 * w)
    assert_allclose(watched.chain_rate, 1.0 + 0.5 * w * excess)
    # the pooled chain reads the chain belief, the alarm's ŝ the gated one
    assert watched.scale == 1.0
    assert noise.pooled([watched.chain_noise]).shape == watched.chain_shape


def test_a_common_change_teaches_neither_belief():
    # a change every operation showed (common): not noise, whatever the gate
    model = ms.Expected(math.log(100.0), 0.01)
    watched = m.watch(
        ms.Monitor(), NEAR, model, Measurement(103.0, 1.0), POINT, EXPONENTS, 0.15, (0.03, 1e-4)
    ).monitor
    assert (watched.chain_shape, watched.chain_rate) == (noise.NOISE_PRIOR, noise.NOISE_RATE)


def test_the_noise_update_takes_out_the_spread_at_the_estimated_noise():
    # learn's expectation: sd 0.02 with its readings at the prudent scale, 0.01 at the
    # estimate; 101 ± 1 (s_n = 0.5/101, r = 0.47 under every alarm): the update uses 0.01,
    # w = s_n² / (1e-4 + s_n²) = 0.19685, excess (ln 1.01² − 1e-4) / s_n² = 0.0
    # (0.0099503² − 1e-4 < 0) -> b unchanged; at 0.02 the weight would be 0.05773
    prudent = ms.Expected(math.log(100.0), 0.02, estimate_sd=0.01)
    s_n2 = (0.5 / 101) ** 2
    watched = _watch(ms.Monitor(), 101.0, prudent).monitor
    assert_allclose(watched.shape, 1.5 + 0.5 * s_n2 / (1e-4 + s_n2))
    assert_allclose(watched.shape, 1.5 + 0.5 * 0.19685, rtol=1e-4)
    assert watched.rate == noise.NOISE_RATE
    # without the estimate the model spread is the whole sd
    plain = _watch(ms.Monitor(), 101.0, ms.Expected(math.log(100.0), 0.02)).monitor
    assert_allclose(plain.shape, 1.5 + 0.5 * s_n2 / (4e-4 + s_n2))
    assert_allclose(plain.shape, 1.5 + 0.5 * 0.05773, rtol=1e-3)


def test_an_old_monitor_reads_its_gated_belief_as_the_chains():
    # a monitor stored before the chain belief had keys of its own
    stored = ms.Monitor(2.5, 4.0).to_json()
    del stored["chain_shape"], stored["chain_rate"]
    back = ms.from_json(stored)
    assert (back.chain_shape, back.chain_rate) == (2.5, 4.0)
    assert ms.from_json(ms.Monitor(2.0, 3.0, chain_shape=4.0, chain_rate=9.0).to_json()) == (
        ms.Monitor(2.0, 3.0, chain_shape=4.0, chain_rate=9.0)
    )


@pytest.fixture(scope="module")
def plan():
    return load_plan(DEMO_PLAN)


def _report(state, factor, version=None):
    """Every maximum the plan predicts at its setpoints, times ``factor`` (u: 2 %)."""
    measurements = {}
    for op in state.setpoints.operations:
        measured = {}
        for quantity in ("force_N", "roughness_um"):
            shown = op.predicted.get(quantity)
            if shown is not None:
                value = shown.value * factor[op.name] if isinstance(factor, dict) else factor
                measured[quantity] = Measurement(value, 0.02 * value)
        measurements[op.name] = measured
    return PartReport("p", state.version if version is None else version, measurements)


def test_after_a_report_every_learned_posterior_is_at_its_chains_prudent_scale(plan):
    # readings scattered 3x more than their u: each operation learns at the chain's scale of
    # the readings before it; once the report is in, all are at the chain's prudent scale
    state = start(plan, RcbSettings(strategy="learn"))
    rng = np.random.default_rng(3)
    names = [op.name for op in state.setpoints.operations]
    factors = {n: float(np.exp(rng.normal(0.0, 0.03))) for n in names}
    after, _ = update(state, _report(state, factors))
    for quantity in ("force_N", "roughness_um"):
        chain = noise.pooled(
            mon.chain_noise for (_, q), mon in after.monitors.items() if q == quantity
        )
        beliefs = [b for (_, q), b in after.posterior.items() if q == quantity]
        assert beliefs
        for belief in beliefs:
            assert_allclose(belief.noise_scale2, chain.prudent_scale**2, rtol=1e-12)
