"""Sensor conversions: Ivester & Heigel Eqs. 1-4, Kim & Jeon §6, Tai et al. Eqs. 13-15."""

from __future__ import annotations

import json
import math
import re
import tomllib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy.optimize import curve_fit

from models import sensors
from models.errors import InputError, ModelDomainError
from models.sensors import (
    IVESTER_SPINDLE_LOAD,
    KIM_JEON_SPINDLE_FMAX_4500RPM,
    Converted,
    FeedDependentCurrentCalibration,
    IvesterSpindleLoadCalibration,
    LinearCurrentCalibration,
    TaiCurrentFeedCalibration,
    calibration_from_current_relation,
    calibration_from_mapping,
    calibration_to_mapping,
    calibrations_from_mapping,
    feed_dependent_force_N,
    fit_linear_calibration,
    fit_tai_calibration,
    ivester_force_N,
    ivester_idle_load_V,
    ivester_load_V,
    ivester_ratio_N_mm_per_V,
    ivester_spindle_torque_Nm,
    kim_jeon_rms_current_A,
    linear_current_force_N,
    rpm_to_rad_s,
    tai_feed_rate_mm_min,
    tai_reference_current_A,
    tai_spindle_current_A,
    to_force,
)

MC_SAMPLES = 200_000

IDLE_TABLE = IvesterSpindleLoadCalibration(
    idle_speeds_rpm=(300.0, 600.0, 1200.0, 2400.0),
    idle_loads_V=(0.20, 0.25, 0.35, 0.55),
    u_idle_load_V=0.01,
    source="test idle table",
)


# --------------------------------------------------------------------------------------------
# Ivester & Heigel Eqs. 1-4


def test_eq1_below_the_corner_speed_hand_computed():
    # Ivester & Heigel Eqs. 1 and 3, by hand:
    #   n = 600 rpm -> φ = 600 · 2π/60 = 62.832 rad/s <= 70.2 rad/s -> Eq. 1: m = 2.19e5 N·mm/V
    #   net load L = 0.80 V − 0.30 V (idle at 600 rpm) = 0.50 V
    #   Eq. 3: F = m·L/D = 2.19e5 · 0.50 / 60 mm = 1825.0 N
    #   torque = F · D/2 = 1825.0 N · 0.030 m = 54.75 N·m  (= m·L/2000 = 2.19e5·0.5/2000)
    #   Eq. 4 with ΔL = 0.01 V, ΔD = 0, Δm = 210 N·mm/V (the default, see the calibration):
    #   ΔF = 1825 · sqrt((0.01/0.50)² + (210/2.19e5)²) = 1825 · sqrt(4.0e-4 + 9.19e-7)
    #      = 1825 · 0.020023 = 36.54 N
    assert_allclose(rpm_to_rad_s(600), 62.832, rtol=1e-5)
    assert ivester_ratio_N_mm_per_V(62.832) == 2.19e5
    force = ivester_force_N(0.80, 0.01, 600, 60, idle_load_V=0.30)
    assert_allclose(force.value, 1825.0, rtol=1e-12)
    assert_allclose(force.uncertainty, 36.54, rtol=1e-3)
    torque = ivester_spindle_torque_Nm(0.80, 0.01, 600, idle_load_V=0.30)
    assert_allclose(torque.value, 54.75, rtol=1e-12)
    assert_allclose(torque.value, force.value * 60 / 2000, rtol=1e-12)  # F = T / r, r = D/2000 m


def test_eq2_above_the_corner_speed_hand_computed():
    # Ivester & Heigel Eqs. 2-4, by hand:
    #   n = 1200 rpm -> φ = 1200 · 2π/60 = 125.664 rad/s > 70.2 -> Eq. 2: m = 1.39e8 · φ^-1.52
    #   ln φ = 4.83361; −1.52 · 4.83361 = −7.34709; e^−7.34709 = 6.4447e-4
    #   m = 1.39e8 · 6.4447e-4 = 89581 N·mm/V
    #   net load L = 0.80 V − 0.35 V = 0.45 V; D = 50 mm
    #   Eq. 3: F = 89581 · 0.45 / 50 = 806.23 N
    #   Eq. 4: ΔL = sqrt(0.01² + 0.01²) = 0.014142 V (load and idle), ΔD = 0.05 mm, Δm = 210
    #   ΔF/F = sqrt((0.05/50)² + (0.014142/0.45)² + (210/89581)²)
    #        = sqrt(1.0e-6 + 9.8765e-4 + 5.4955e-6) = 0.031530 -> ΔF = 25.42 N
    assert_allclose(ivester_ratio_N_mm_per_V(rpm_to_rad_s(1200)), 89581, rtol=1e-4)
    force = ivester_force_N(
        0.80, 0.01, 1200, 50, idle_load_V=0.35, u_idle_load_V=0.01, u_workpiece_diameter_mm=0.05
    )
    assert_allclose(force.value, 806.23, rtol=1e-4)
    assert_allclose(force.uncertainty, 25.42, rtol=1e-3)


def test_corner_speed_selects_eq1_at_and_eq2_above_70_2_rad_s():
    # Eq. 1 holds for φ <= 70.2 rad/s; Eq. 2 above. As printed they do not meet:
    # 1.39e8 · 70.2^-1.52 = 2.1706e5, 0.9 % below Eq. 1's 2.19e5.
    assert ivester_ratio_N_mm_per_V(70.2) == 2.19e5
    assert_allclose(ivester_ratio_N_mm_per_V(70.2 + 1e-9), 2.1706e5, rtol=1e-4)
    corner_rpm = 70.2 * 60 / (2 * math.pi)  # 670.36 rpm
    low = ivester_force_N(1.0, 0.0, corner_rpm, 50, idle_load_V=0.0)
    high = ivester_force_N(1.0, 0.0, corner_rpm * 1.0001, 50, idle_load_V=0.0)
    assert_allclose(low.value, 2.19e5 / 50, rtol=1e-12)
    assert high.value < low.value


def test_default_delta_m_is_the_papers_0_21_read_as_N_m_per_V_at_2s():
    # Ivester & Heigel, text after Eq. 3: Δm = ±0.21 (±2s). Read as N·m/V of torque F·D/2 per
    # volt: 0.21 · 2 · 1000 = 420 N·mm/V of Eq. 3's m; standard uncertainty 420/2 = 210.
    assert IVESTER_SPINDLE_LOAD.u_m_N_mm_per_V == 210.0
    assert "Eqs. 1-4" in IVESTER_SPINDLE_LOAD.reference


@pytest.mark.parametrize("speed_rpm", [600.0, 1200.0])
def test_eq4_against_monte_carlo(speed_rpm):
    # Eq. 4 (first order) vs a Monte Carlo of L, L_idle, D and m, on both sides of 70.2 rad/s.
    cal = IvesterSpindleLoadCalibration(u_m_N_mm_per_V=3000.0)  # larger Δm to exercise its term
    load, u_load, idle, u_idle, d, u_d = 0.80, 0.01, 0.30, 0.008, 60.0, 0.2
    first_order = ivester_force_N(
        load,
        u_load,
        speed_rpm,
        d,
        idle_load_V=idle,
        u_idle_load_V=u_idle,
        u_workpiece_diameter_mm=u_d,
        calibration=cal,
    )
    rng = np.random.default_rng(20240501)
    m0 = ivester_ratio_N_mm_per_V(rpm_to_rad_s(speed_rpm), cal)
    m = rng.normal(m0, cal.u_m_N_mm_per_V, MC_SAMPLES)
    forces = (
        m
        * (rng.normal(load, u_load, MC_SAMPLES) - rng.normal(idle, u_idle, MC_SAMPLES))
        / rng.normal(d, u_d, MC_SAMPLES)
    )
    assert_allclose(forces.mean(), first_order.value, rtol=0.01)
    assert_allclose(forces.std(ddof=1), first_order.uncertainty, rtol=0.05)


def test_idle_load_from_the_table_is_interpolated_in_speed():
    # "The net spindle load is obtained by subtracting the idle load measured at the same
    # spindle speed without cutting" (Ivester & Heigel, before Eq. 1): 900 rpm lies halfway
    # between 600 (0.25 V) and 1200 rpm (0.35 V) -> 0.30 V.
    idle = ivester_idle_load_V(900, IDLE_TABLE)
    assert_allclose(idle.value, 0.30, rtol=1e-12)
    assert idle.uncertainty == 0.01
    with pytest.raises(ModelDomainError) as err:
        ivester_idle_load_V(3000, IDLE_TABLE)
    assert err.value.field == "spindle_speed_rpm"


def test_to_force_spindle_load_uses_the_idle_table_or_a_measured_idle_load():
    # 900 rpm = 94.25 rad/s > 70.2: m = 1.39e8 · 94.25^-1.52; net = 0.80 − 0.30 V; D = 60 mm
    m = 1.39e8 * rpm_to_rad_s(900) ** -1.52
    ctx = {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60, "feed_mm_rev": 0.3}
    force, u_force = to_force(IDLE_TABLE, "spindle_load_V", 0.80, 0.02, ctx)
    assert_allclose(force, m * 0.50 / 60, rtol=1e-12)
    # expanded in, expanded out (k = 2): ΔF = 2·u_F with u_L = sqrt(0.01² + 0.01²)
    u_std = ivester_force_N(0.80, 0.01, 900, 60, idle_load_V=0.30, u_idle_load_V=0.01,
                            calibration=IDLE_TABLE).uncertainty  # fmt: skip
    assert_allclose(u_force, 2 * u_std, rtol=1e-12)
    measured = to_force(
        IDLE_TABLE, "spindle_load_V", 0.80, 0.02, {**ctx, "idle_load_V": 0.40, "u_idle_load_V": 0}
    )
    assert_allclose(measured.value, m * 0.40 / 60, rtol=1e-12)


@settings(max_examples=200, deadline=None)
@given(
    force=st.floats(0.0, 5000.0),
    speed=st.floats(50.0, 4000.0),
    diameter=st.floats(5.0, 300.0),
    idle=st.floats(0.0, 2.0),
)
def test_round_trip_force_load_force(force, speed, diameter, idle):
    load = ivester_load_V(force, speed, diameter, idle_load_V=idle)
    back = ivester_force_N(load, 0.0, speed, diameter, idle_load_V=idle)
    assert back.value == pytest.approx(force, rel=1e-9, abs=1e-9)


@settings(max_examples=200, deadline=None)
@given(
    idle=st.floats(0.0, 1.0),
    step1=st.floats(1e-3, 5.0),
    step2=st.floats(1e-3, 5.0),
    speed=st.floats(50.0, 4000.0),
)
def test_force_rises_with_load_above_idle(idle, step1, step2, speed):
    f1 = ivester_force_N(idle + step1, 0.0, speed, 50.0, idle_load_V=idle).value
    f2 = ivester_force_N(idle + step1 + step2, 0.0, speed, 50.0, idle_load_V=idle).value
    assert 0 < f1 < f2


# --------------------------------------------------------------------------------------------
# Kim & Jeon §6


def test_rms_of_three_phase_currents_hand_computed():
    # Kim & Jeon §6: I_RMS = sqrt((I_U² + I_V² + I_W²)/3)
    #   (4.0, 4.2, 3.8) A: 16.00 + 17.64 + 14.44 = 48.08; /3 = 16.0267; sqrt = 4.00333 A
    #   u_I = sqrt(Σ (I_p u_p / (3 I))²) = 0.05 · sqrt(48.08) / (3 · 4.00333)
    #       = 0.05 · 6.93397 / 12.0100 = 0.028867 A
    rms = kim_jeon_rms_current_A([4.0, 4.2, 3.8], [0.05, 0.05, 0.05])
    assert_allclose(rms.value, 4.00333, rtol=1e-5)
    assert_allclose(rms.uncertainty, 0.028867, rtol=1e-4)
    # a balanced instantaneous sample (3, −1.5, −1.5) A: 9 + 2.25 + 2.25 = 13.5; /3 = 4.5;
    # sqrt = 2.12132 A, the per-phase RMS of a 3 A amplitude (3/√2)
    assert_allclose(kim_jeon_rms_current_A([3.0, -1.5, -1.5]).value, 3 / math.sqrt(2))
    # the paper prints sqrt(I_U² + I_V² + I_W²)/3 = sqrt(48.08)/3 = 2.3113 A, √3 smaller
    assert not math.isclose(rms.value, math.sqrt(48.08) / 3, rel_tol=0.1)


def test_rms_uncertainty_against_monte_carlo():
    currents, u = np.array([4.0, 4.2, 3.8]), np.array([0.05, 0.08, 0.03])
    first_order = kim_jeon_rms_current_A(currents, u)
    rng = np.random.default_rng(7)
    samples = rng.normal(currents, u, (MC_SAMPLES, 3))
    rms = np.sqrt((samples**2).mean(axis=1))
    assert_allclose(rms.std(ddof=1), first_order.uncertainty, rtol=0.05)


def _kim_jeon_150_mpm_data():
    """Synthetic calibration cuts on the paper's 150 mpm relation I = 5.762e-3 F + 3.206 A."""
    rng = np.random.default_rng(11)
    forces = np.linspace(40.0, 400.0, 15)
    currents = 5.762e-3 * forces + 3.206 + rng.normal(0.0, 0.02, forces.size)
    return currents, forces


def test_linear_fit_matches_numpy_polyfit():
    currents, forces = _kim_jeon_150_mpm_data()
    cal = fit_linear_calibration(currents, forces, source="test cuts", feed_rate_mm_min=150)
    (slope, offset), cov = np.polyfit(currents, forces, 1, cov=True)  # cov scaled by s²/(n−2)
    assert_allclose([cal.offset_N, cal.slope_N_per_A], [offset, slope], rtol=1e-9)
    # polyfit orders (slope, offset); ours is (offset, slope)
    assert_allclose(np.array(cal.covariance), cov[::-1, ::-1], rtol=1e-9)
    residuals = forces - (offset + slope * currents)
    assert_allclose(cal.residual_sd_N, math.sqrt(residuals @ residuals / (forces.size - 2)))
    assert cal.n == 15 and cal.feed_rate_mm_min == 150 and cal.source == "test cuts"
    # the fitted slope is the inverse of the paper's sensitivity, 1/5.762e-3 = 173.55 N/A
    assert_allclose(cal.slope_N_per_A, 173.55, rtol=0.05)


def test_papers_current_relation_inverts_to_force():
    # Kim & Jeon §6.2.3, 150 mpm: I = 5.762e-3 F + 3.206 A. For F = 230 N:
    #   I = 5.762e-3 · 230 + 3.206 = 1.32526 + 3.206 = 4.53126 A
    #   F = (I − 3.206)/5.762e-3: offset a = −3.206/5.762e-3 = −556.40 N, slope 173.55 N/A
    cal = calibration_from_current_relation(5.762e-3, 3.206, feed_rate_mm_min=150)
    assert_allclose([cal.offset_N, cal.slope_N_per_A], [-556.40, 173.55], rtol=1e-5)
    assert_allclose(linear_current_force_N(cal, 4.53126).value, 230.0, rtol=1e-9)


def test_papers_2_506_A_for_230_N_is_not_on_its_current_relations():
    # Kim & Jeon §7 sets "2.506 A, which was equivalent to the maximum cutting force 230 N";
    # the §6.2.3 relations at 4500 rpm put 230 N at 4.43-4.91 A (offsets alone are 3.2-3.5 A),
    # so 2.506 A is below every zero-force current: an inconsistency of the paper.
    for point in KIM_JEON_SPINDLE_FMAX_4500RPM.points:
        current_230 = (230 - point.offset_N) / point.slope_N_per_A
        assert 4.4 < current_230 < 4.95
    with pytest.raises(ModelDomainError) as err:
        to_force(
            KIM_JEON_SPINDLE_FMAX_4500RPM,
            "spindle_current_A",
            2.506,
            0.0,
            {"spindle_speed_rpm": 4500, "feed_rate_mm_min": 300},
        )
    assert err.value.field == "spindle_current_A.value"


def test_converted_force_uncertainty_against_monte_carlo():
    currents, forces = _kim_jeon_150_mpm_data()
    cal = fit_linear_calibration(currents, forces, source="test cuts")
    current, u_current = 4.4, 0.01
    first_order = linear_current_force_N(cal, current, u_current, include_residual=True)
    rng = np.random.default_rng(3)
    params = rng.multivariate_normal([cal.offset_N, cal.slope_N_per_A], cal.covariance, MC_SAMPLES)
    sampled = (
        params[:, 0]
        + params[:, 1] * rng.normal(current, u_current, MC_SAMPLES)
        + rng.normal(0.0, cal.residual_sd_N, MC_SAMPLES)
    )
    assert_allclose(sampled.mean(), first_order.value, rtol=0.01)
    assert_allclose(sampled.std(ddof=1), first_order.uncertainty, rtol=0.05)
    without = linear_current_force_N(cal, current, u_current, include_residual=False)
    assert_allclose(without.uncertainty**2 + cal.residual_sd_N**2, first_order.uncertainty**2)


def test_slope_depends_on_feed_by_interpolation_between_calibrated_feeds():
    # Kim & Jeon §6.2.3: lines at 150, 300, 450 mpm (N_s = 4500 rpm). At I = 4.6 A:
    #   150 mpm: F = (4.6 − 3.206)/5.762e-3 = 241.93 N
    #   300 mpm: F = (4.6 − 3.537)/5.981e-3 = 177.73 N
    #   225 mpm lies halfway: F = (241.93 + 177.73)/2 = 209.83 N
    cal = KIM_JEON_SPINDLE_FMAX_4500RPM
    at_150 = feed_dependent_force_N(cal, 4.6, 0.0, 150)
    at_300 = feed_dependent_force_N(cal, 4.6, 0.0, 300)
    at_225 = feed_dependent_force_N(cal, 4.6, 0.0, 225)
    assert_allclose([at_150.value, at_300.value, at_225.value], [241.93, 177.73, 209.83], rtol=1e-4)
    with pytest.raises(ModelDomainError) as err:
        feed_dependent_force_N(cal, 4.6, 0.0, 500)
    assert err.value.field == "feed_rate_mm_min"


def test_feed_dependent_uncertainty_against_monte_carlo():
    rng = np.random.default_rng(5)
    points = []
    for feed, sens, offset in ((150.0, 5.762e-3, 3.206), (300.0, 5.981e-3, 3.537)):
        forces = np.linspace(40.0, 400.0, 12)
        currents = sens * forces + offset + rng.normal(0.0, 0.02, forces.size)
        points.append(fit_linear_calibration(currents, forces, feed_rate_mm_min=feed))
    cal = FeedDependentCurrentCalibration(points=tuple(points), source="test")
    current, u_current, feed, u_feed = 4.6, 0.01, 200.0, 5.0
    first_order = feed_dependent_force_N(
        cal, current, u_current, feed, u_feed_rate_mm_min=u_feed, include_residual=False
    )
    i = rng.normal(current, u_current, MC_SAMPLES)
    f = rng.normal(feed, u_feed, MC_SAMPLES)
    w = (f - 150.0) / 150.0
    lo, hi = (rng.multivariate_normal([p.offset_N, p.slope_N_per_A], p.covariance, MC_SAMPLES)
              for p in points)  # fmt: skip
    sampled = (1 - w) * (lo[:, 0] + lo[:, 1] * i) + w * (hi[:, 0] + hi[:, 1] * i)
    assert_allclose(sampled.mean(), first_order.value, rtol=0.01)
    assert_allclose(sampled.std(ddof=1), first_order.uncertainty, rtol=0.05)


@settings(max_examples=100, deadline=None)
@given(
    offset=st.floats(0.0, 1000.0),
    slope=st.floats(10.0, 1000.0),
    currents=st.lists(st.floats(0.0, 20.0), min_size=3, max_size=20, unique=True).filter(
        lambda xs: max(xs) - min(xs) > 0.1
    ),
)
def test_fit_recovers_an_exact_line(offset, slope, currents):
    cal = fit_linear_calibration(currents, [offset + slope * i for i in currents])
    scale = offset + 20 * slope
    assert cal.slope_N_per_A == pytest.approx(slope, rel=1e-6)
    assert cal.offset_N == pytest.approx(offset, abs=1e-9 * scale)
    assert cal.residual_sd_N == pytest.approx(0.0, abs=1e-9 * scale)


# --------------------------------------------------------------------------------------------
# Tai, Tsai & Li Eqs. 13-15

# A, B, k1 from the paper's own end-milling numbers (§III.A), three points (f, VB, I):
#   sharp tool: I = 0.24 A at about 1000 mm/min (Fig. 4)                  (1000, 0,      0.240)
#   700 mm/min: current close to 0.24 A at VB = 167.3 µm (Fig. 7)         ( 700, 0.1673, 0.240)
#   600 mm/min: current 0.236 A at VB = 205.1 µm (Fig. 7)                 ( 600, 0.2051, 0.236)
# Eq. 14, I = A + B f + k1 VB, minus the first point:
#   (2) − (1): 0 = −300 B + 0.1673 k1          -> k1 = 1793.2 B
#   (3) − (1): −0.004 = −400 B + 0.2051 k1 = −400 B + 367.78 B = −32.22 B
#   B = 1.2416e-4 A/(mm/min); k1 = 0.22263 A/mm (2.2263e-4 A/µm); A = 0.24 − 0.12416 = 0.11584 A
TAI_B = 0.004 / (400 - 300 * 0.2051 / 0.1673)
TAI_K1 = 300 * TAI_B / 0.1673
TAI_A = 0.24 - 1000 * TAI_B


def test_tai_constants_from_the_papers_numbers():
    assert_allclose([TAI_A, TAI_B, TAI_K1], [0.11584, 1.2416e-4, 0.22263], rtol=1e-4)


def _tai_tests(noise_A=0.0, seed=0):
    """Constant-feed tests on the paper-derived plane: sharp-tool feeds and worn tools."""
    rng = np.random.default_rng(seed)
    feeds, wears = [], []
    for f in (600.0, 700.0, 800.0, 900.0, 1000.0, 1100.0):  # sharp tools (Fig. 4)
        feeds += [f] * 3  # "three cutting tests were carried out for each cutting condition"
        wears += [0.0] * 3
    for f in (600.0, 700.0):  # wear tests at constant feed (Fig. 7)
        for vb in (0.05, 0.10, 0.15, 0.20):
            feeds.append(f)
            wears.append(vb)
    feeds, wears = np.array(feeds), np.array(wears)
    currents = TAI_A + TAI_B * feeds + TAI_K1 * wears + rng.normal(0.0, noise_A, feeds.size)
    return feeds, wears, currents


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


# --------------------------------------------------------------------------------------------
# to_force: the entry point, and bad data


def test_to_force_with_a_linear_current_calibration():
    cal = LinearCurrentCalibration(
        offset_N=-556.4, slope_N_per_A=173.55, u_offset_N=4.0, u_slope_N_per_A=1.0,
        corr_offset_slope=-0.9, residual_sd_N=3.0, source="test",
    )  # fmt: skip
    force = to_force(cal, "spindle_current_A", 4.5, 0.02, {})
    standard = linear_current_force_N(cal, 4.5, 0.01)
    assert_allclose(force.value, -556.4 + 173.55 * 4.5)
    assert_allclose(force.uncertainty, 2 * standard.uncertainty)
    assert isinstance(force, Converted)


@pytest.mark.parametrize(
    ("calibration", "raw", "value", "uncertainty", "context", "field"),
    [
        (IDLE_TABLE, "spindle_load_V", 0.8, 0.01, {"workpiece_diameter_mm": 60},
         "context.spindle_speed_rpm"),
        (IDLE_TABLE, "spindle_load_V", 0.8, 0.01, {"spindle_speed_rpm": 900},
         "context.workpiece_diameter_mm"),
        (IVESTER_SPINDLE_LOAD, "spindle_load_V", 0.8, 0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60}, "context.idle_load_V"),
        (IDLE_TABLE, "spindle_load_V", 0.8, 0.01,
         {"spindle_speed_rpm": "fast", "workpiece_diameter_mm": 60}, "context.spindle_speed_rpm"),
        (IDLE_TABLE, "spindle_load_V", 0.8, 0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": -60}, "context.workpiece_diameter_mm"),
        (IDLE_TABLE, "spindle_load_V", 0.8, 0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": math.nan},
         "context.workpiece_diameter_mm"),
        (IDLE_TABLE, "spindle_load_V", 0.8, 0.01,
         {"spindle_speed_rpm": 9000, "workpiece_diameter_mm": 60}, "context.spindle_speed_rpm"),
        (IDLE_TABLE, "spindle_load_V", math.nan, 0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60}, "spindle_load_V.value"),
        (IDLE_TABLE, "spindle_load_V", "0.8", 0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60}, "spindle_load_V.value"),
        (IDLE_TABLE, "spindle_load_V", -0.8, 0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60}, "spindle_load_V.value"),
        (IDLE_TABLE, "spindle_load_V", 0.1, 0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60}, "spindle_load_V.value"),
        (IDLE_TABLE, "spindle_load_V", 0.8, -0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60}, "spindle_load_V.uncertainty"),
        (IDLE_TABLE, "spindle_current_A", 0.8, 0.01,
         {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60}, "raw_quantity"),
        (IDLE_TABLE, "spindle_power_kW", 0.8, 0.01, {}, "raw_quantity"),
        (KIM_JEON_SPINDLE_FMAX_4500RPM, "spindle_current_A", 4.5, 0.01,
         {"spindle_speed_rpm": 4500}, "context.feed_rate_mm_min"),
        (KIM_JEON_SPINDLE_FMAX_4500RPM, "spindle_current_A", 4.5, 0.01,
         {"feed_rate_mm_min": 300}, "context.spindle_speed_rpm"),
        (KIM_JEON_SPINDLE_FMAX_4500RPM, "spindle_current_A", 4.5, 0.01,
         {"spindle_speed_rpm": 3000, "feed_rate_mm_min": 300}, "context.spindle_speed_rpm"),
        (KIM_JEON_SPINDLE_FMAX_4500RPM, "spindle_current_A", 4.5, 0.01,
         {"spindle_speed_rpm": 4500, "feed_rate_mm_min": 600}, "context.feed_rate_mm_min"),
        (TaiCurrentFeedCalibration(TAI_A, TAI_B, TAI_K1), "spindle_current_A", 0.2, 0.0, {},
         "calibration.kind"),
        (object(), "spindle_current_A", 0.2, 0.0, {}, "calibration.kind"),
    ],
)  # fmt: skip
def test_to_force_bad_data_names_the_field(calibration, raw, value, uncertainty, context, field):
    with pytest.raises(InputError) as err:
        to_force(calibration, raw, value, uncertainty, context)
    assert err.value.field == field


def test_to_force_path_names_the_reading():
    with pytest.raises(InputError) as err:
        to_force(IDLE_TABLE, "spindle_load_V", math.inf, 0.01,
                 {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60},
                 path="operations[0].measurements.spindle_load_V")  # fmt: skip
    assert err.value.field == "operations[0].measurements.spindle_load_V.value"


@pytest.mark.parametrize(
    ("call", "field"),
    [
        (lambda: ivester_force_N(True, 0.0, 600, 60, idle_load_V=0.3), "load_V"),
        (lambda: ivester_force_N(0.8, 0.0, 0, 60, idle_load_V=0.3), "spindle_speed_rpm"),
        (lambda: ivester_force_N(0.8, 0.0, 600, None, idle_load_V=0.3), "workpiece_diameter_mm"),
        (lambda: ivester_force_N(0.8, math.nan, 600, 60, idle_load_V=0.3), "u_load_V"),
        (lambda: kim_jeon_rms_current_A([1.0, 2.0]), "phase_currents_A"),
        (lambda: kim_jeon_rms_current_A([1.0, "2", 3.0]), "phase_currents_A[1]"),
        (lambda: kim_jeon_rms_current_A([1.0, 2.0, 3.0], [0.1, -0.1, 0.1]),
         "u_phase_currents_A[1]"),
        (lambda: fit_linear_calibration([1.0, 2.0], [10.0, 20.0]), "currents_A"),
        (lambda: fit_linear_calibration([1.0, 1.0, 1.0], [10.0, 20.0, 30.0]), "currents_A"),
        (lambda: fit_linear_calibration([1.0, 2.0, 3.0], [10.0, 20.0]), "forces_N"),
        (lambda: fit_linear_calibration([1.0, math.nan, 3.0], [1.0, 2.0, 3.0]), "currents_A[1]"),
        (lambda: fit_linear_calibration([1.0, 2.0, 3.0], [1.0, -2.0, 3.0]), "forces_N[1]"),
        (lambda: fit_linear_calibration(3.0, [1.0, 2.0, 3.0]), "currents_A"),
        (lambda: fit_linear_calibration([1.0, 2.0, 3.0], [30.0, 20.0, 10.0]), "forces_N"),
        (lambda: LinearCurrentCalibration(0.0, -1.0), "slope_N_per_A"),
        (lambda: LinearCurrentCalibration(0.0, 1.0, corr_offset_slope=1.5), "corr_offset_slope"),
        (lambda: tai_feed_rate_mm_min(TaiCurrentFeedCalibration(0.1, 1e-4), 0.05), "current_A"),
        (lambda: TaiCurrentFeedCalibration(0.1, 1e-4, 0.2, corr_idle_slope=0.9,
                                           corr_idle_wear=0.9, corr_slope_wear=-0.9),
         "corr_idle_slope"),
        (lambda: tai_reference_current_A(0.28, 1.17), "factor"),
        (lambda: IvesterSpindleLoadCalibration(idle_speeds_rpm=(600.0, 300.0),
                                               idle_loads_V=(0.2, 0.3)), "idle_speeds_rpm"),
        (lambda: IvesterSpindleLoadCalibration(idle_speeds_rpm=(300.0, 600.0),
                                               idle_loads_V=(0.2,)), "idle_loads_V"),
        (lambda: FeedDependentCurrentCalibration(points=(LinearCurrentCalibration(0, 1),)),
         "points"),
        (lambda: FeedDependentCurrentCalibration(
            points=(LinearCurrentCalibration(0, 1), LinearCurrentCalibration(0, 2))),
         "points[0].feed_rate_mm_min"),
    ],
)  # fmt: skip
def test_bad_arguments_name_the_field(call, field):
    with pytest.raises(InputError) as err:
        call()
    assert err.value.field == field


# --------------------------------------------------------------------------------------------
# plan-file format


def _docstring_toml():
    """The TOML example of the module docstring, so that the documentation stays true."""
    doc = sensors.__doc__
    block = doc[doc.index("::\n") + 3 : doc.index("Read them with")]
    return tomllib.loads("\n".join(line[4:] for line in block.splitlines()))


def test_docstring_example_reads():
    plan = _docstring_toml()
    cals = calibrations_from_mapping(plan["machine"]["calibrations"], "machine.calibrations")
    load = cals["spindle_load"]
    assert isinstance(load, IvesterSpindleLoadCalibration)
    assert load.idle_speeds_rpm == (300.0, 600.0, 1200.0, 2400.0)
    assert load.m_low_N_mm_per_V == 2.19e5
    assert isinstance(cals["spindle_current"], LinearCurrentCalibration)
    assert cals["spindle_current"].spindle_speed_rpm == 4500
    by_feed = cals["spindle_current_by_feed"]
    assert isinstance(by_feed, FeedDependentCurrentCalibration)
    assert by_feed.feed_rates_mm_min == (150.0, 300.0)
    assert isinstance(cals["milling_current"], TaiCurrentFeedCalibration)
    force, u_force = to_force(
        load, "spindle_load_V", 0.9, 0.02, {"spindle_speed_rpm": 900, "workpiece_diameter_mm": 60}
    )
    assert force > 0 and u_force > 0


def test_defaults_of_a_minimal_spindle_load_table_are_the_papers():
    cal = calibration_from_mapping(
        {"kind": "ivester_spindle_load", "source": "paper"}, "machine.calibrations.load"
    )
    assert cal == IvesterSpindleLoadCalibration(source="paper")
    assert (cal.m_low_N_mm_per_V, cal.m_coefficient, cal.m_exponent) == (2.19e5, 1.39e8, -1.52)
    assert cal.corner_speed_rad_s == 70.2


@pytest.mark.parametrize(
    "calibration",
    [
        IVESTER_SPINDLE_LOAD,
        IDLE_TABLE,
        KIM_JEON_SPINDLE_FMAX_4500RPM,
        fit_linear_calibration(*_kim_jeon_150_mpm_data(), date="2024-05-02", notes="cuts 1-15"),
        fit_tai_calibration(*_tai_tests(noise_A=0.002), source="test"),
    ],
)
def test_mapping_round_trip(calibration):
    table = calibration_to_mapping(calibration)
    assert calibration_from_mapping(table, "c") == calibration
    assert calibration_from_mapping(json.loads(json.dumps(table)), "c") == calibration


def test_numpy_scalars_are_stored_as_plain_floats():
    cal = LinearCurrentCalibration(np.int64(-500), np.float32(170.0), n=3, source="test")
    assert type(cal.offset_N) is float and type(cal.slope_N_per_A) is float
    json.dumps(calibration_to_mapping(cal))


def test_toml_date_is_read_as_iso_text():
    data = tomllib.loads(
        'kind = "linear_current"\nsource = "s"\ndate = 2024-05-02\n'
        "offset_N = -556.4\nslope_N_per_A = 173.55\n"
    )
    assert calibration_from_mapping(data, "c").date == "2024-05-02"


P = "machine.calibrations.x"


@pytest.mark.parametrize(
    ("table", "field"),
    [
        ({"source": "s"}, f"{P}.kind"),
        ({"kind": "kistler_dynamometer", "source": "s"}, f"{P}.kind"),
        ({"kind": 3, "source": "s"}, f"{P}.kind"),
        ({"kind": "ivester_spindle_load"}, f"{P}.source"),
        ({"kind": "ivester_spindle_load", "source": ""}, f"{P}.source"),
        ({"kind": "ivester_spindle_load", "source": "s", "m_exponent": "x"}, f"{P}.m_exponent"),
        ({"kind": "ivester_spindle_load", "source": "s", "m_low_N_mm_per_V": -1},
         f"{P}.m_low_N_mm_per_V"),
        ({"kind": "ivester_spindle_load", "source": "s", "u_m_N_mm_per_V": math.nan},
         f"{P}.u_m_N_mm_per_V"),
        ({"kind": "ivester_spindle_load", "source": "s", "m_slope": 1}, f"{P}.m_slope"),
        ({"kind": "ivester_spindle_load", "source": "s", "idle_speeds_rpm": [1, 2]},
         f"{P}.idle_loads_V"),
        ({"kind": "ivester_spindle_load", "source": "s", "idle_speeds_rpm": [1, 2],
          "idle_loads_V": [0.1, "x"]}, f"{P}.idle_loads_V[1]"),
        ({"kind": "ivester_spindle_load", "source": "s", "idle_speeds_rpm": [1, 2],
          "idle_loads_V": [0.1, -0.2]}, f"{P}.idle_loads_V[1]"),
        ({"kind": "linear_current", "source": "s", "slope_N_per_A": 1}, f"{P}.offset_N"),
        ({"kind": "linear_current", "source": "s", "offset_N": 1}, f"{P}.slope_N_per_A"),
        ({"kind": "linear_current", "source": "s", "offset_N": 1, "slope_N_per_A": 0},
         f"{P}.slope_N_per_A"),
        ({"kind": "linear_current", "source": "s", "offset_N": 1, "slope_N_per_A": 1,
          "u_offset_N": -1}, f"{P}.u_offset_N"),
        ({"kind": "linear_current", "source": "s", "offset_N": 1, "slope_N_per_A": 1,
          "n": 2.5}, f"{P}.n"),
        ({"kind": "linear_current", "source": "s", "offset_N": True, "slope_N_per_A": 1},
         f"{P}.offset_N"),
        ({"kind": "linear_current_by_feed", "source": "s"}, f"{P}.points"),
        ({"kind": "linear_current_by_feed", "source": "s", "points": {"a": 1}}, f"{P}.points"),
        ({"kind": "linear_current_by_feed", "source": "s",
          "points": [{"offset_N": 1, "slope_N_per_A": 1}]}, f"{P}.points[0].feed_rate_mm_min"),
        ({"kind": "linear_current_by_feed", "source": "s",
          "points": [{"feed_rate_mm_min": 1, "offset_N": 1, "slope_N_per_A": 1}]},
         f"{P}.points"),
        ({"kind": "linear_current_by_feed", "source": "s",
          "points": [{"feed_rate_mm_min": 1, "offset_N": 1, "slope_N_per_A": 1},
                     {"feed_rate_mm_min": 2, "offset_N": 1, "slope_N_per_A": "steep"}]},
         f"{P}.points[1].slope_N_per_A"),
        ({"kind": "tai_current_feed", "source": "s", "idle_current_A": 0.1},
         f"{P}.slope_A_per_mm_min"),
        ({"kind": "tai_current_feed", "source": "s", "idle_current_A": 0.1,
          "slope_A_per_mm_min": 1e-4, "corr_slope_wear": -2}, f"{P}.corr_slope_wear"),
        ("not a table", P),
    ],
)  # fmt: skip
def test_mapping_errors_name_the_dotted_field(table, field):
    with pytest.raises(InputError) as err:
        calibration_from_mapping(table, P)
    assert err.value.field == field


def test_every_public_function_cites_its_paper():
    cited = re.compile(r"Ivester|Kim & Jeon|Tai")
    for name in dir(sensors):
        obj = getattr(sensors, name)
        if (
            callable(obj)
            and getattr(obj, "__module__", "") == "models.sensors"
            and name.split("_")[0] in {"ivester", "kim", "tai", "fit", "linear", "feed", "to"}
            and not name.endswith("_from_mapping")
        ):
            assert cited.search(obj.__doc__ or ""), name
