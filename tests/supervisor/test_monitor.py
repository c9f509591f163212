"""What RCB watches in the readings (supervisor.rcb.monitor), with hand-computed numbers.

Every figure follows the module docstring: ``r = e / √(s² + ŝ²(s_c² + s_n²))`` with
``s_n = (u/2)/y``; a reading is quarantined under ``r < −6`` or under half the expectation's
lower 2σ edge, a change over ``r > 4``, and the noise scale ``λ ~ InvGamma(a, b)`` starts at
``a = 1.5, b = 1``.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy.stats import invgamma

from supervisor.inputs.part_report import Measurement
from supervisor.rcb import monitor as m
from supervisor.rcb import monitor_state as ms
from supervisor.rcb import noise
from supervisor.rcb.learning import rescaled
from supervisor.rcb.posterior import Posterior

POINT = {"feed_mm_rev": 0.3}
EXPONENTS = {"feed_mm_rev": 0.8}
#: What a strategy expects: ln y ~ ln 100 ± 0.05 (a 5 % spread).
NEAR = ms.Expected(math.log(100.0), 0.05)


def _watch(monitor, y, u=1.0, low=NEAR, high=None, point=POINT):
    return m.watch(monitor, low, high, Measurement(y, u), point, EXPONENTS, 0.15)


def test_a_reading_six_sigma_under_the_expectation_is_quarantined():
    # 73 ± 1: e = ln 0.73 = −0.3147, s_n = 0.5/73 = 0.00685, σ = √(0.05² + 0.00685²) = 0.05047
    low = _watch(ms.Monitor(), 73.0)
    assert low.verdict == "quarantine" and not low.learns
    assert_allclose(low.sigma, -0.31471 / 0.050467, rtol=1e-4)  # −6.236
    assert low.monitor.held is not None and low.monitor.quarantined == 1
    # 76 ± 1: e = −0.2744, r = −5.44: accepted, nothing held
    near = _watch(ms.Monitor(), 76.0)
    assert near.verdict == "accept" and near.monitor.held is None


def test_under_half_the_lower_edge_is_quarantined_however_wide_the_prior():
    # ln y ~ ln 100 ± 0.3: 30 ± 1 is r = −1.204 / 0.3005 = −4.0 (over −6) and e = −1.204 over
    # −(ln 2 + 2 · 0.3) = −1.293: accepted; 25 ± 1 (e = −1.386) is under half the lower edge
    wide = ms.Expected(math.log(100.0), 0.3)
    assert _watch(ms.Monitor(), 30.0, low=wide).verdict == "accept"
    assert _watch(ms.Monitor(), 25.0, low=wide).verdict == "quarantine"


def test_the_next_consistent_reading_confirms_a_quarantined_one():
    held = _watch(ms.Monitor(), 73.0).monitor
    # 73.5 at the same point: d = ln(73.5/73) = 0.00683, joint noise √(0.00685² + 0.00680²)
    # = 0.00965, 3σ = 0.0290: consistent; the process moved down (regime change), and the old
    # regime is discounted by q = e² − (0.05² + 0.00685²) = 0.09904 − 0.00255 = 0.09650
    confirmed = _watch(held, 73.5)
    assert confirmed.verdict == "confirm" and confirmed.changed and confirmed.learns
    assert confirmed.held == held.held
    assert_allclose(confirmed.forget, math.log(0.73) ** 2 - (0.05**2 + (0.5 / 73) ** 2))
    assert confirmed.monitor.held is None and confirmed.monitor.changes == 1
    # 80 instead: d = 0.0914 > 0.029, not consistent; 80 itself is plausible (r = −4.4)
    dropped = _watch(held, 80.0)
    assert dropped.verdict == "accept" and dropped.monitor.held is None


def test_a_reading_more_than_a_factor_two_low_is_never_confirmed():
    # 40 is e = −0.916 under the expectation: lower than ln 2; a second 40 is quarantined too
    held = _watch(ms.Monitor(), 40.0).monitor
    again = _watch(held, 40.0)
    assert again.verdict == "quarantine" and again.monitor.quarantined == 2


def test_a_reading_four_sigma_over_a_tight_expectation_is_a_change():
    tight = ms.Expected(math.log(100.0), 0.01)
    # 105 ± 1: e = 0.04879, s_n = 0.5/105 = 0.004762, σ = √(1e-4 + 2.268e-5) = 0.011076,
    # r = 4.405 > 4; q = e² − σ² = 0.0023806 − 0.0001227 = 0.0022579
    change = _watch(ms.Monitor(), 105.0, low=tight, high=tight)
    assert change.verdict == "change" and change.changed and change.monitor.changes == 1
    assert_allclose(change.sigma, 4.405, rtol=1e-3)
    assert_allclose(change.forget, 0.0022579, rtol=1e-4)
    # 104 ± 1: r = 0.03922 / 0.011071 = 3.54: no change
    assert _watch(ms.Monitor(), 104.0, low=tight, high=tight).verdict == "accept"


def test_the_noise_scale_learns_from_a_successive_difference():
    # the chain's last reading moved to the setpoint: mean ln 100, its own noise 0.005, no
    # model spread; 101 ± 1 (s_n = 0.00495): the whole innovation is noise (weight 1),
    # e² / (s_c² + s_n²) = 0.009950² / 4.950e-5 = 2.000: a = 1.5 + 0.5, b = 1 + 0.5 · 2.0
    chain = ms.Expected(math.log(100.0), 0.0, 0.005)
    after = _watch(ms.Monitor(), 101.0, high=chain).monitor
    assert_allclose(after.shape, 2.0)
    assert_allclose(after.rate, 1.0 + 0.5 * math.log(1.01) ** 2 / (0.005**2 + (0.5 / 101) ** 2))
    assert_allclose(after.scale, math.sqrt(max(after.rate / after.shape, 1.0)))
    upper = invgamma(after.shape, scale=after.rate).ppf(noise.PRUDENT_QUANTILE)
    assert_allclose(after.noise.prudent_scale, math.sqrt(upper))
    # the same difference after a setpoint move the exponents explain by more than the noise
    # (shift 0.8 · ln 1.1 = 0.0762): it says more about the exponents, nothing is learned
    moved = ms.Expected(math.log(100.0), 0.0, 0.005, 0.8 * math.log(1.1))
    assert _watch(ms.Monitor(), 101.0, high=moved).monitor.shape == ms.Monitor().shape


def test_before_any_reading_the_law_takes_u_as_reported_and_learn_a_prudent_one():
    fresh = ms.Monitor()
    assert fresh.scale == 1.0  # √max(1 / 1.5, 1)
    # the upper quantile of InvGamma(1.5, 1): 0.95 -> 5.6843 (u x 2.3842), 0.93 -> 4.4569
    # (x 2.1111), as scipy.stats.invgamma.ppf gives them
    expected = {0.95: 5.684300, 0.93: 4.456937}[noise.PRUDENT_QUANTILE]
    assert_allclose(fresh.noise.prudent_scale, math.sqrt(expected), rtol=1e-6)


def test_the_chains_noise_adds_every_operations_evidence():
    # two operations read by one chain: evidence (0.5, 0.5) and (1.0, 2.0) over the prior
    # (1.5, 1): the chain's belief is (3.0, 3.5), ŝ = √(3.5 / 3.0)
    first, second = ms.Monitor(2.0, 1.5), ms.Monitor(2.5, 3.0)
    chain = noise.pooled([first.noise, second.noise])
    assert (chain.shape, chain.rate) == (3.0, 3.5)
    assert_allclose(chain.scale, math.sqrt(3.5 / 3.0))
    assert noise.pooled([]) == noise.NoiseScale()  # no reading yet: the prior


@pytest.mark.parametrize(("factor", "low", "high"), [(1.0, 1.0, 1.2), (3.0, 2.4, 3.6)])
def test_the_noise_scale_finds_the_chains_noise(factor, low, high):
    # 400 readings of one setpoint whose noise is factor × the reported u/2, each judged
    # against the last (the chain of ivester and bayes): ŝ ends near the factor
    rng = np.random.default_rng(5)
    monitor = ms.Monitor()
    u = 2.0
    for _ in range(400):
        y = 100.0 * math.exp(factor * 0.01 * rng.standard_normal())
        high_side = m.chain(monitor, POINT, EXPONENTS, 0.15)
        watched = _watch(monitor, y, u=u, low=ms.Expected(math.log(100.0), 0.5), high=high_side)
        monitor = m.learned(watched.monitor, Measurement(y, u), POINT, None)
    assert low <= monitor.scale <= high


def test_the_chain_moves_the_last_reading_with_the_exponents_and_a_worn_edges_rise():
    monitor = m.learned(ms.Monitor(), Measurement(100.0, 1.0), POINT, 2)
    moved = {"feed_mm_rev": 0.33}
    # 0.8 · ln 1.1 = 0.07625 higher, misfit (0.15 · 0.07625)² = 1.308e-4; two parts of a rise
    # 0.01 ± 0.005 per part: + 0.02, variance + 4 · 2.5e-5
    expected = m.chain(monitor, moved, EXPONENTS, 0.15, 4, (0.01, 2.5e-5))
    assert expected is not None
    assert_allclose(expected.mean, math.log(100.0) + 0.8 * math.log(1.1) + 0.02)
    assert_allclose(expected.sd, math.sqrt((0.15 * 0.8 * math.log(1.1)) ** 2 + 1e-4))
    assert_allclose(expected.noise, 0.005)
    assert m.chain(monitor, moved, EXPONENTS, 0.15, 1, (0.01, 2.5e-5)) is None  # a new edge


@given(
    shape=st.floats(1.01, 50),
    rate=st.floats(0.01, 500),
    quarantined=st.integers(0, 1000),
    y=st.floats(1e-3, 1e4),
    alarm=st.floats(0, 20),
)
def test_a_monitor_survives_its_json(shape, rate, quarantined, y, alarm):
    reading = ms.Reading(math.log(y), 0.01, {"feed_mm_rev": -1.2}, 3)
    monitor = ms.Monitor(shape, rate, reading, reading, quarantined, 2)
    assert ms.from_json(monitor.to_json()) == monitor
    watched = replace(monitor, noise_llr=-alarm / 3, chain_alarm=alarm)  # noise_watch's
    assert ms.from_json(watched.to_json()) == watched
    assert monitor.scale >= 1.0 and monitor.noise.prudent_scale >= monitor.scale


def test_rescaled_counts_the_readings_at_the_new_noise_scale():
    # an intercept alone: prior N(0, 0.1²) (precision 100), one reading ln y = 0.05 at noise
    # 0.01 (precision 1e4): posterior precision 10100, mean 0.05 · 1e4 / 10100 = 0.0495049.
    # At a noise scale λ = 4 the reading's precision is 2500: 2600, mean 0.05 · 2500 / 2600
    prior = Posterior("force_N", (), (), {}, (0.0,), ((0.01,),))
    posterior = Posterior("force_N", (), (), {}, (0.05 * 1e4 / 10100,), ((1 / 10100,),), 1)
    wider = rescaled(posterior, prior, 4.0)
    assert_allclose(wider.cov[0][0], 1 / 2600, rtol=1e-9)
    assert_allclose(wider.mean[0], 0.05 * 2500 / 2600, rtol=1e-9)
    assert wider.noise_scale2 == 4.0
    # and back: the chain proved quiet, the reading weighs 1e4 again
    back = rescaled(wider, prior, 1.0)
    assert_allclose(back.cov[0][0], 1 / 10100, rtol=1e-9)
    assert_allclose(back.mean[0], posterior.mean[0], rtol=1e-9)
    assert rescaled(wider, prior, 4.0) is wider


def test_rescaled_is_kept_per_scale_and_prior_not_per_belief_alone():
    # the result is kept on the belief (a reading, its learning and the report's end ask for
    # it); another prior at the same scale is another answer: against a tighter prior
    # N(0, 0.05²) (precision 400) the readings are P − P₀ = 10100 − 400 = 9700, at λ = 4
    # 2425: 400 + 2425 = 2825, not the 2600 of the first prior's
    prior = Posterior("force_N", (), (), {}, (0.0,), ((0.01,),))
    tight = Posterior("force_N", (), (), {}, (0.0,), ((0.0025,),))
    posterior = Posterior("force_N", (), (), {}, (0.05 * 1e4 / 10100,), ((1 / 10100,),), 1)
    first = rescaled(posterior, prior, 4.0)
    assert rescaled(posterior, prior, 4.0) is first
    assert rescaled(posterior, Posterior(*(getattr(prior, f) for f in _FIELDS)), 4.0) is first
    other = rescaled(posterior, tight, 4.0)
    assert_allclose(other.cov[0][0], 1 / 2825, rtol=1e-9)
    assert_allclose(rescaled(posterior, prior, 4.0).cov[0][0], 1 / 2600, rtol=1e-9)


_FIELDS = ("quantity", "names", "center", "context_exponents", "mean", "cov")


def test_readings_a_little_over_part_after_part_are_a_change_by_cusum():
    # ln y ~ ln 100 ± 0.01, readings 103 ± 0.001 (noise negligible): e = ln 1.03 = 0.029559,
    # r = 2.9559 each (under the one-reading threshold 4); S = max(0, S + r − 0.5): 2.456,
    # 4.912 (under h = 6), 7.368: the third reading is a change, its discount the mean shift²
    # less the variance of a mean of three, 0.029559² − 1e-4 / 3 = 8.4040e-4
    tight = ms.Expected(math.log(100.0), 0.01)
    monitor = ms.Monitor()
    for expected_s in (2.4559, 4.9118):
        watched = _watch(monitor, 103.0, u=0.001, low=tight, high=tight)
        assert watched.verdict == "accept"
        assert_allclose(watched.monitor.cusum, expected_s, rtol=1e-4)
        monitor = watched.monitor
    third = _watch(monitor, 103.0, u=0.001, low=tight, high=tight)
    assert third.verdict == "change" and third.monitor.cusum == 0.0
    assert_allclose(third.forget, math.log(1.03) ** 2 - 1e-4 / 3, rtol=1e-4)
    # 99 (r = −1.005) only lowers S to 3.407; 95 (r = −5.13) brings it back to 0 and forgets
    assert_allclose(
        _watch(monitor, 99.0, u=0.001, low=tight, high=tight).monitor.cusum, 3.4067, rtol=1e-4
    )
    back = _watch(monitor, 95.0, u=0.001, low=tight, high=tight).monitor
    assert (back.cusum, back.drift_sum, back.drift_n) == (0.0, 0.0, 0)


def test_a_drift_in_progress_off_the_model_teaches_the_noise_nothing():
    # ln y ~ ln 100 ± 0.01 (a model's expectation, no chain noise); 103 ± 1 has s_n =
    # 0.5/103 = 0.004854, r = ln 1.03 / hypot(0.01, 0.004854) = 2.6591; with the CUSUM at 0
    # it would stand at 2.159 after it, over 2: the reading is part of a drift, not noise
    model = ms.Expected(math.log(100.0), 0.01)
    r = math.log(1.03) / math.hypot(0.01, 0.5 / 103)
    assert_allclose(r, 2.6591, rtol=1e-4)
    gated = m.watch(ms.Monitor(), NEAR, model, Measurement(103.0, 1.0), POINT, EXPONENTS, 0.15)
    assert_allclose(gated.monitor.cusum, r - 0.5)
    assert (gated.monitor.shape, gated.monitor.rate) == (ms.Monitor().shape, ms.Monitor().rate)
    # 102 (r = 1.7783, the CUSUM at 1.278, under 2) teaches it: weight s_n² / (s² + s_n²),
    # s_n = 0.5/102: 0.19373
    quiet = m.watch(ms.Monitor(), NEAR, model, Measurement(102.0, 1.0), POINT, EXPONENTS, 0.15)
    noise2 = (0.5 / 102) ** 2
    assert_allclose(quiet.monitor.shape, 1.5 + 0.5 * 0.19373, rtol=1e-4)
    assert_allclose(quiet.monitor.shape, 1.5 + 0.5 * noise2 / (1e-4 + noise2))
    # a successive difference (the chain's last reading, noise 0.005) is not gated
    chain = ms.Expected(math.log(100.0), 0.01, 0.005)
    judged = m.watch(ms.Monitor(), NEAR, chain, Measurement(103.0, 1.0), POINT, EXPONENTS, 0.15)
    assert judged.monitor.shape > ms.Monitor().shape


def test_the_paper_law_judges_a_low_reading_against_the_last_one_not_the_catalogue():
    # ivester, rough-od Ra: the catalogue predicts 3.176 ± 0.8235 µm at the robust start
    # (Ivester & Heigel Table 4), s = 0.8235 / 3.176 / 2 = 0.1296 in ln. A reading at 0.55 of
    # it, e = ln 0.55 = −0.598, is r = −4.6 against the catalogue (not quarantined: −6) but,
    # once one reading is in, is judged against that reading moved to the new setpoint:
    # its noise 0.09 / 2 / 3.176 = 0.0142 and the move's exponent misfit make r ≪ −6
    from rcb_support import _report, paper_start

    from supervisor.rcb.update import update

    state = paper_start()
    ra = state.setpoints.operations[0].predicted["roughness_um"]
    assert_allclose((ra.value, ra.band), (3.176, 0.8235), atol=0.001)
    r_catalogue = math.log(0.55) / math.sqrt(
        (ra.band / ra.value / 2) ** 2 + (0.09 / 2 / ra.value) ** 2
    )
    assert -6 < r_catalogue < -4.5
    on_model = {"rough-od": {"roughness_um": Measurement(ra.value, 0.09)}}
    state, _ = update(state, _report(state, on_model))
    now = state.setpoints.operations[0].predicted["roughness_um"].value
    low = {"rough-od": {"roughness_um": Measurement(0.55 * now, 0.09)}}
    _, (d,) = update(state, _report(state, low))
    assert d.note == "implausible_low" and d.action == "hold"
    assert d.band_after == d.band_before  # nothing learned from it
