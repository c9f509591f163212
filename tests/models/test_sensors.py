"""Sensor conversions: Ivester & Heigel Eqs. 1-4, Kim & Jeon §6.

Tai et al. Eqs. 13-15: test_sensors_tai.py; to_force, bad data and the plan-file format:
test_sensors_to_force.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from sensors_support import IDLE_TABLE, MC_SAMPLES, _kim_jeon_150_mpm_data

from models.errors import ModelDomainError
from models.sensors import (
    IVESTER_SPINDLE_LOAD,
    KIM_JEON_SPINDLE_FMAX_4500RPM,
    FeedDependentCurrentCalibration,
    IvesterSpindleLoadCalibration,
    calibration_from_current_relation,
    feed_dependent_force_N,
    fit_linear_calibration,
    ivester_force_N,
    ivester_idle_load_V,
    ivester_load_V,
    ivester_ratio_N_mm_per_V,
    ivester_spindle_torque_Nm,
    kim_jeon_rms_current_A,
    linear_current_force_N,
    rpm_to_rad_s,
    to_force,
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
