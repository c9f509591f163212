"""Sensor conversions: Tai, Tsai & Li Eqs. 13-15, on the plane derived from the paper's own
numbers (tests/sensors_support.py).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy.optimize import curve_fit
from sensors_support import MC_SAMPLES, TAI_A, TAI_B, TAI_K1, _tai_tests

from models.errors import InputError
from models.sensors import (
    TaiCurrentFeedCalibration,
    fit_tai_calibration,
    tai_feed_rate_mm_min,
    tai_reference_current_A,
    tai_spindle_current_A,
)

# --------------------------------------------------------------------------------------------
# Tai, Tsai & Li Eqs. 13-15


def test_tai_constants_from_the_papers_numbers():
    assert_allclose([TAI_A, TAI_B, TAI_K1], [0.11584, 1.2416e-4, 0.22263], rtol=1e-4)


def test_reference_current_gives_the_upper_feed_limit():
    # Tai et al. §III.A: reference current = 0.85 × 0.28 A = 0.238 A (printed as 0.24 A);
    # "the feedrate corresponding to the initial spindle current of 0.24 A without any tool
    # wear was about 1000 mm/min. Therefore, the upper limit of the feedrate ... 1000 mm/min."
    feeds, wears, currents = _tai_tests()
    cal = fit_tai_calibration(feeds, wears, currents, source="paper-derived plane")
    i_ref = tai_reference_current_A(0.28)
    assert_allclose(i_ref, 0.238, rtol=1e-12)
    # the line passes through (1000 mm/min, 0.24 A)
    assert_allclose(tai_spindle_current_A(cal, 1000.0).value, 0.24, rtol=1e-9)
    assert_allclose(tai_feed_rate_mm_min(cal, 0.24).value, 1000.0, rtol=1e-9)
    # Eq. 15 at VB = 0 and I = 0.238 A: f = (0.238 − 0.11584)/1.2416e-4 = 983.89 mm/min, the
    # feed where the line's current is exactly 0.238 A; "about 1000" (the paper rounds 0.238)
    upper = tai_feed_rate_mm_min(cal, i_ref)
    assert_allclose(upper.value, 983.89, rtol=1e-5)
    assert_allclose(tai_spindle_current_A(cal, upper.value).value, 0.238, rtol=1e-9)
    assert upper.value == pytest.approx(1000.0, rel=0.02)


def test_lower_feed_limit_at_the_largest_wear():
    # Tai et al. after Eq. 15: "f_m is the minimum and lower limit of feedrate when V_B reaches
    # the maximum"; the paper's 600 mm/min end-milling limit drew 0.236 A at VB = 205.1 µm:
    #   f = (0.236 − 0.11584)/1.2416e-4 − (0.22263/1.2416e-4)·0.2051 = 967.8 − 367.8 = 600 mm/min
    cal = TaiCurrentFeedCalibration(TAI_A, TAI_B, TAI_K1, source="Tai et al. §III.A")
    assert_allclose(tai_feed_rate_mm_min(cal, 0.236, 0.2051).value, 600.0, rtol=1e-9)
    assert tai_feed_rate_mm_min(cal, 0.236, 0.2051).value < tai_feed_rate_mm_min(cal, 0.236).value


def test_tai_fit_matches_scipy_curve_fit():
    feeds, wears, currents = _tai_tests(noise_A=0.002, seed=1)
    cal = fit_tai_calibration(feeds, wears, currents, source="test")
    popt, pcov = curve_fit(
        lambda x, a, b, k1: a + b * x[0] + k1 * x[1],
        np.vstack([feeds, wears]),
        currents,
        p0=[0.1, 1e-4, 0.2],
    )
    assert_allclose(
        [cal.idle_current_A, cal.slope_A_per_mm_min, cal.wear_coefficient_A_per_mm],
        popt,
        rtol=1e-6,
    )
    assert_allclose(cal.covariance, pcov, rtol=1e-5)
    assert cal.n == feeds.size


def test_tai_feed_uncertainty_against_monte_carlo():
    feeds, wears, currents = _tai_tests(noise_A=0.002, seed=2)
    cal = fit_tai_calibration(feeds, wears, currents, source="test")
    i_ref, u_i, vb, u_vb = 0.238, 0.001, 0.15, 0.01
    first_order = tai_feed_rate_mm_min(cal, i_ref, vb, u_current_A=u_i, u_flank_wear_mm=u_vb)
    rng = np.random.default_rng(9)
    beta = [cal.idle_current_A, cal.slope_A_per_mm_min, cal.wear_coefficient_A_per_mm]
    p = rng.multivariate_normal(beta, cal.covariance, MC_SAMPLES)
    i = rng.normal(i_ref, u_i, MC_SAMPLES)
    w = rng.normal(vb, u_vb, MC_SAMPLES)
    sampled = (i - p[:, 0] - p[:, 2] * w) / p[:, 1]
    assert_allclose(np.median(sampled), first_order.value, rtol=0.01)
    assert_allclose(sampled.std(ddof=1), first_order.uncertainty, rtol=0.05)


@settings(max_examples=200, deadline=None)
@given(feed=st.floats(0.0, 3000.0), wear=st.floats(0.0, 0.5))
def test_tai_current_feed_round_trip(feed, wear):
    cal = TaiCurrentFeedCalibration(TAI_A, TAI_B, TAI_K1, source="Tai et al.")
    current = tai_spindle_current_A(cal, feed, wear).value
    assert tai_feed_rate_mm_min(cal, current, wear).value == pytest.approx(feed, abs=1e-6)


def test_tai_fit_needs_wear_variation_to_identify_k1():
    with pytest.raises(InputError) as err:
        fit_tai_calibration([600, 700, 800, 900], [0, 0, 0, 0], [0.19, 0.2, 0.21, 0.23])
    assert err.value.field == "flank_wears_mm"
