"""A measuring chain that turns noisier late in a plan's life is believed within tens of parts.

The chain's noise evidence keeps ``1 − 1/M`` of itself per reading (``M`` =
``noise.NOISE_MEMORY``; West & Harrison §10.8, variance discounting). Without it, 500 quiet
readings outweighed the noisier ones for hundreds of parts, and ``learn`` counted its readings
three times too precise: a chain 3x noisier from part 500 crossed 417 limits in 30 scenarios
x 1000 parts (docs/benchmarks.md, *A year of parts*).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from supervisor.inputs.part_report import Measurement
from supervisor.rcb import monitor as m
from supervisor.rcb import monitor_state as ms
from supervisor.rcb import noise

POINT = {"feed_mm_rev": 0.3}
EXPONENTS = {"feed_mm_rev": 0.8}
#: What the model expects: ln 100, known to 0.1 % (the readings' noise is what is learned).
EXPECTED = ms.Expected(math.log(100.0), 0.001)
#: The reported noise of a reading, in ln: u = 2 x 1 % of the value (k = 2).
U_REL = 0.02


def _readings(monitor, rng, count, true_scale):
    """``count`` readings whose noise is ``true_scale`` x what their u says."""
    for _ in range(count):
        y = 100.0 * math.exp(rng.normal(0.0, true_scale * U_REL / 2))
        watched = m.watch(
            monitor, EXPECTED, EXPECTED, Measurement(y, U_REL * y), POINT, EXPONENTS, 0.15
        )
        monitor = watched.monitor
    return monitor


def test_each_reading_keeps_the_memorys_share_of_the_evidence_before_it():
    # a monitor with 40 readings' worth (a = 1.5 + 20, b = 1.0 + 30) and one reading of
    # weight w, excess x: a' = 1.5 + (1 − 1/M)^w · 20 + w/2, b' = 1.0 + (1 − 1/M)^w · 30 + w x/2
    before = ms.Monitor(chain_shape=21.5, chain_rate=31.0)
    y = 101.0
    watched = m.watch(before, EXPECTED, EXPECTED, Measurement(y, 2.0), POINT, EXPONENTS, 0.15)
    s_n2 = (1.0 / y) ** 2
    w = s_n2 / (0.001**2 + s_n2)
    excess = (math.log(y / 100.0) ** 2 - 0.001**2) / s_n2
    keep = (1.0 - 1.0 / noise.NOISE_MEMORY) ** w
    after = watched.monitor
    assert_allclose(after.chain_shape, 1.5 + keep * 20.0 + 0.5 * w)
    assert_allclose(after.chain_rate, 1.0 + keep * 30.0 + 0.5 * w * excess)
    # the operation's own belief (the alarm's and the band law's ŝ) keeps everything
    assert after.shape == before.shape + 0.5 * w


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_chain_three_times_noisier_after_500_quiet_readings_is_believed_in_60(seed):
    rng = np.random.default_rng(seed)
    quiet = _readings(ms.Monitor(), rng, 500, 1.0)
    assert quiet.chain_noise.prudent_scale < 1.4
    noisy = _readings(quiet, rng, 60, 3.0)
    # without the memory: (500 x 1 + 60 x 9) / 560 -> a scale of about 1.4 after 60 readings
    assert noisy.chain_noise.prudent_scale > 2.4
    assert noisy.chain_noise.scale > 2.0


def test_a_quiet_chain_stays_believed_quiet():
    # the memory costs a quiet chain only its quantile: 2000 readings at the reported noise
    monitor = _readings(ms.Monitor(), np.random.default_rng(3), 2000, 1.0)
    assert monitor.chain_noise.scale < 1.2
    assert monitor.chain_noise.prudent_scale < 1.45
