"""Inner feed-control loops of the virtual mill (issue 7, part 2).

Kim & Jeon (Precision Engineering 2011) Eq. 1, Table 2 and Case 1; Tai, Tsai & Li (IEEE Access
2023) Eqs. 14-16 and Tables 1-2; Borangiu et al. (IFAC 2007) Table 1.

Here the force models, the plant, the acceptance runs (Case 1 under each controller, the edge
life to the tool change) and bad input; the controllers themselves (Tai et al.'s PI, Kim &
Jeon's fuzzy rules, Borangiu et al.'s corrective actions) in test_mill_controllers.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from models.errors import InputError
from models.milling_force import (
    KimJeonForceModel,
    PowerLawForce,
    feed_for_force_mm_min,
    kim_jeon_coefficients,
    kim_jeon_forces_N,
    kim_jeon_max_force_N,
)
from models.powerlaw import PowerLawModel
from supervisor.virtual.mill import (
    CONTROLLERS,
    EdgeLifeConfig,
    FeedLimits,
    ForceCurrentMill,
    MillSetup,
    StepWorkpiece,
    TaiMill,
    case1_controller,
    run_case1,
    simulate,
    simulate_edge_life,
    tai_wear_at_feed_mm,
)
from supervisor.virtual.mill.controllers import CorrectiveConfig, TaiPIController, TaiPIGains
from supervisor.virtual.mill.tai_end_milling import (
    TAI_END_MILLING,
    TAI_LOWER_FEED_RATE_MM_MIN,
    TAI_PRINTED_LOWER_FEED_RATE_MM_MIN,
)

KJ = KimJeonForceModel()

# --------------------------------------------------------------------------------------------
# Kim & Jeon Eq. 1


def test_chip_thickness_power_laws_hand_computed():
    # Kim & Jeon §3: f = 60 mpm, N_s = 1500 rpm, M = 2 -> f_t = 60/3000 = 0.02 mm
    #   t_c = 2·0.02/π = 0.0127324 mm; ln t_c = −4.36361
    #   K_s  = 800 · e^(0.197·4.36361) = 800 · e^0.859630 = 800 · 2.36229 = 1889.83 N/mm²
    #   K_rt = 0.163 · e^(0.353·4.36361) = 0.163 · e^1.540354 = 0.163 · 4.66601 = 0.760560
    ks, krt = kim_jeon_coefficients(KJ, 0.02)
    assert_allclose([ks, krt], [1889.83, 0.76060], rtol=1e-4)


def test_max_force_per_revolution_hand_computed():
    # Eq. 1 at f = 60 mm/min, d = 1.5 mm, 1500 rpm, D = 10 mm, helix 30° (h = π·10/tan 30°
    # = 54.414 mm, the reading of "h"):
    #   a = K_s K_rt f_t d/2 = 1889.83·0.76060·0.015 = 21.561 N;  b = K_s f_t d/2 = 28.347 N
    #   2πd/h = 0.173205 rad, sin = 0.172340; sqrt(1 + K_rt²) = 1.256387
    #   A = K_s f_t h/(4π) · 0.172340 · 1.256387 = 163.664 · 0.216528 = 35.437 N
    #   s = +1: hypot(57.00, −7.09) = 57.44 N;  s = −1: hypot(−13.88, 63.78) = 65.28 N
    assert_allclose(KJ.helix_lead_mm, 54.414, rtol=1e-4)
    assert_allclose(kim_jeon_max_force_N(KJ, 60.0, 1.5, 1500.0), 65.28, rtol=2e-4)


@pytest.mark.parametrize(("feed", "depth"), [(60.0, 1.5), (190.0, 1.5), (80.0, 3.0)])
def test_closed_form_maximum_equals_the_maximum_over_the_revolution(feed, depth):
    angles = np.linspace(0.0, 2.0 * math.pi, 20001)
    forces = [math.hypot(*kim_jeon_forces_N(KJ, feed, depth, 1500.0, a)) for a in angles]
    assert_allclose(kim_jeon_max_force_N(KJ, feed, depth, 1500.0), max(forces), rtol=1e-6)


def test_feeds_that_hold_160_N_against_kim_jeon_case1_simulation():
    # Kim & Jeon §5.1: the FLC held 160 N "by lowering the feed rate to 70 mpm" at d = 3.0 mm
    # and "increased the feed rate to 190 mpm" at d = 1.5 mm (read off their Fig. 5c).
    # The model gives 193.94 and 79.72 mm/min: 2 % and 14 % above the paper's values.
    at_1_5 = feed_for_force_mm_min(KJ, 160.0, 1.5, 1500.0)
    at_3_0 = feed_for_force_mm_min(KJ, 160.0, 3.0, 1500.0)
    assert_allclose([at_1_5, at_3_0], [193.94, 79.72], rtol=1e-4)
    assert at_1_5 == pytest.approx(190.0, rel=0.05)
    assert at_3_0 == pytest.approx(70.0, rel=0.15)


@settings(max_examples=100, deadline=None)
@given(
    feed=st.floats(5.0, 500.0),
    depth=st.floats(0.1, 8.0),
    more=st.floats(1.01, 2.0),
)
def test_force_rises_with_feed_and_depth(feed, depth, more):
    force = kim_jeon_max_force_N(KJ, feed, depth, 1500.0)
    assert kim_jeon_max_force_N(KJ, feed * more, depth, 1500.0) > force > 0
    assert kim_jeon_max_force_N(KJ, feed, depth * more, 1500.0) > force


def test_no_force_without_feed_or_depth():
    assert kim_jeon_max_force_N(KJ, 0.0, 1.5, 1500.0) == 0.0
    assert kim_jeon_max_force_N(KJ, 100.0, 0.0, 1500.0) == 0.0


def test_power_law_force_hand_computed():
    # F = 1000 · ap^0.9 · fz^0.75: ap = 2 mm, fz = 300/(1000·4) = 0.075 mm
    #   2^0.9 = 1.86607; 0.075^0.75 = e^(0.75·ln 0.075) = e^(−1.94272) = 0.143327
    #   F = 1000 · 1.86607 · 0.143327 = 267.46 N
    model = PowerLawModel(
        "force_N", 1000.0, 0.0, {"axial_depth_mm": 0.9, "feed_per_tooth_mm": 0.75}
    )
    force = PowerLawForce(model, radial_depth_mm=5.0, tool_diameter_mm=10.0, flute_count=4)
    assert_allclose(force.force_N(300.0, 2.0, 1000.0), 267.46, rtol=1e-4)
    assert force.force_N(0.0, 2.0, 1000.0) == 0.0


# --------------------------------------------------------------------------------------------
# Plant: current relations and workpiece


def test_current_relation_of_the_case1_mill():
    # Kim & Jeon §6.2.3 (150 mpm): I = 5.762e-3 F + 3.206 A; 160 N -> 0.92192 + 3.206 = 4.12792 A
    mill = ForceCurrentMill(KJ)
    feed = feed_for_force_mm_min(KJ, 160.0, 1.5, 1500.0)
    assert_allclose(mill.current_A(feed, 1.5, 1500.0, 0.0), 4.12792, rtol=1e-6)
    assert mill.current_A(feed, 0.0, 1500.0, 0.0) == 3.206  # air cut: idle current
    worn = ForceCurrentMill(KJ, wear_force_N_per_mm=100.0, wear_current_A_per_mm=0.5)
    # 0.2 mm of wear: +20 N of force (+0.11524 A) and +0.1 A
    assert_allclose(worn.current_A(feed, 1.5, 1500.0, 0.2), 4.12792 + 0.11524 + 0.1, rtol=1e-6)


def test_tai_plane_from_the_papers_points():
    # Tai et al. §III.A (see tests/sensors_support.py): A = 0.11584 A, B = 1.2416e-4 A/(mm/min),
    # k1 = 0.22263 A/mm; the plane passes through (1000, 0, 0.240) and (600, 0.2051, 0.236).
    cal = TAI_END_MILLING
    assert_allclose(
        [cal.idle_current_A, cal.slope_A_per_mm_min, cal.wear_coefficient_A_per_mm],
        [0.11584, 1.2416e-4, 0.22263],
        rtol=1e-4,
    )
    mill = TaiMill(cal)
    assert_allclose(mill.current_A(1000.0, 0.2, 10000.0, 0.0), 0.240, rtol=1e-12)
    assert_allclose(mill.current_A(600.0, 0.2, 10000.0, 0.2051), 0.236, rtol=1e-12)
    # half the depth, half the cutting current: 0.11584 + 0.12416/2 = 0.17792 A
    assert_allclose(mill.current_A(1000.0, 0.1, 10000.0, 0.0), 0.17792, rtol=1e-4)
    assert math.isnan(mill.force_N(1000.0, 0.2, 10000.0, 0.0))


def test_lower_feed_limit_from_eq15_and_the_papers_600_inconsistency():
    # Eq. 15 at 0.24 A and VB = 205.1 µm: (0.24 − 0.11584)/1.2416e-4 − (0.22263/1.2416e-4)·0.2051
    #   = 1000.0 − 1793.2·0.2051 = 1000.0 − 367.8 = 632.2 mm/min
    assert_allclose(TAI_LOWER_FEED_RATE_MM_MIN, 632.2, rtol=1e-4)
    # The printed 600 mm/min at 0.24 A: VB = (0.24 − 0.11584 − 0.074494)/0.22263 = 223.1 µm,
    # outside the 180-220 µm interval (the paper chose 600 from a 0.236 A reading).
    assert TAI_PRINTED_LOWER_FEED_RATE_MM_MIN == 600.0
    assert_allclose(tai_wear_at_feed_mm(TAI_END_MILLING, 0.24, 600.0), 0.2231, rtol=1e-3)


def test_step_workpiece_depths():
    piece = StepWorkpiece(((20.0, 1.5), (15.0, 3.0), (20.0, 1.5)))
    assert piece.length_mm == 55.0
    assert piece.boundaries_mm == (20.0, 35.0, 55.0)
    depths = [piece.depth_mm(x) for x in (-1.0, 0.0, 19.99, 20.0, 34.99, 35.0, 54.99, 55.0)]
    assert depths == [0.0, 1.5, 1.5, 3.0, 3.0, 1.5, 1.5, 0.0]


# --------------------------------------------------------------------------------------------
# Acceptance: Case 1 under each controller


@pytest.fixture(scope="module", params=CONTROLLERS)
def case1(request):
    return request.param, run_case1(request.param, seed=0)


def test_case1_holds_the_force_within_5_percent_in_each_segment(case1):
    name, run = case1
    assert [s.depth_mm for s in run.segments] == [1.5, 3.0, 1.5]
    assert run.reference_force_N == pytest.approx(160.0)
    for segment in run.segments:
        assert segment.deviation_max_rel < 0.05, (name, segment)
        assert segment.deviation_mean_rel < 0.05, (name, segment)


def test_case1_steady_feeds_are_the_models_holding_feeds(case1):
    # 160 N is held at 193.94 mm/min (1.5 mm) and 79.72 mm/min (3.0 mm); the fuzzy controller
    # rests at the edge of its ±2 % deadband, so its feeds sit up to 2.5 % lower.
    name, run = case1
    holding = (193.94, 79.72, 193.94)
    for segment, feed in zip(run.segments, holding, strict=True):
        assert segment.feed_mean_steady_mm_min == pytest.approx(feed, rel=0.03), name


def test_case1_feed_never_leaves_its_limits(case1):
    _, run = case1
    low, high = run.limits.lower_feed_rate_mm_min, run.limits.upper_feed_rate_mm_min
    for feeds in (run.feed_command_mm_min, run.feed_rate_mm_min):
        assert np.all(feeds >= low) and np.all(feeds <= high)
    assert run.position_mm[-1] >= 55.0  # the whole path was cut
    with pytest.raises(ValueError):
        run.force_N[0] = 0.0  # frozen series


def test_case1_step_up_overshoots_then_recovers(case1):
    # Kim & Jeon §5.2: "when d was 3 mm, the cutting force overshoot to 300 N"
    _, run = case1
    middle = run.segments[1]
    inside = (run.time_s >= middle.start_s) & (run.time_s <= middle.end_s)
    assert 280.0 < run.force_N[inside].max() < 340.0


@pytest.mark.parametrize("name", CONTROLLERS)
def test_case1_is_deterministic_per_seed(name):
    a, b, c = run_case1(name, seed=7), run_case1(name, seed=7), run_case1(name, seed=8)
    for series in ("measured", "feed_command_mm_min", "force_N"):
        assert np.array_equal(getattr(a, series), getattr(b, series))
    assert not np.array_equal(a.measured, c.measured)


# --------------------------------------------------------------------------------------------
# Acceptance: edge life to the tool change (Tai et al. Tables 1-2)


@pytest.mark.parametrize("seed", range(10))
def test_edge_life_ends_inside_the_tool_change_interval(seed):
    # Tai et al. Table 1: wear when the feed reached its lower limit 175-214 µm (avg 197.26)
    edge = simulate_edge_life(EdgeLifeConfig(), np.random.default_rng(seed))
    assert edge.changed and edge.inside_interval, edge.flank_wear_at_change_mm
    assert edge.run.feed_command_mm_min[-1] == pytest.approx(632.2, rel=1e-4)
    # "within 1 % of the reference current before the feedrate reached the lower limit"
    for summary in edge.passes[:-1]:
        assert summary.current_mean_A == pytest.approx(0.24, rel=0.01)
    feeds = [p.feed_mean_mm_min for p in edge.passes]
    wears = [p.flank_wear_end_mm for p in edge.passes]
    assert feeds[0] > 950.0 and feeds[-1] < 700.0
    assert all(b > a for a, b in zip(wears, wears[1:], strict=False))


def test_edge_life_without_spread_ends_at_the_wear_the_limit_was_set_for():
    # Eq. 15 sets 632.2 mm/min for 0.24 A at 205.1 µm; the PI tracks the wear ramp with a
    # small lag (current ~0.27 mA above 0.24 A), so the feed touches the limit at ~205.8 µm.
    config = EdgeLifeConfig(wear_rate_spread=0.0, wear_coefficient_spread=0.0, noise_sd_A=0.0)
    edge = simulate_edge_life(config, np.random.default_rng(0))
    assert edge.flank_wear_at_change_mm == pytest.approx(0.2051, abs=0.0015)
    # cut length ≈ 0.2058 mm / (3.131e-4 mm/mm³ · 0.28 mm²) = 2347 mm (paper: 2250 mm average)
    assert edge.cut_length_mm == pytest.approx(2347.0, rel=0.01)


def test_edge_life_with_the_printed_600_limit_leaves_the_interval():
    config = EdgeLifeConfig(
        limits=FeedLimits(TAI_PRINTED_LOWER_FEED_RATE_MM_MIN, 1000.0),
        wear_rate_spread=0.0,
        wear_coefficient_spread=0.0,
        noise_sd_A=0.0,
    )
    edge = simulate_edge_life(config, np.random.default_rng(0))
    assert edge.flank_wear_at_change_mm == pytest.approx(0.2231, abs=0.0015)
    assert not edge.inside_interval


def test_edge_life_is_deterministic_per_seed():
    a = simulate_edge_life(EdgeLifeConfig(), np.random.default_rng(3))
    b = simulate_edge_life(EdgeLifeConfig(), np.random.default_rng(3))
    assert np.array_equal(a.run.feed_command_mm_min, b.run.feed_command_mm_min)
    assert a.flank_wear_at_change_mm == b.flank_wear_at_change_mm


# --------------------------------------------------------------------------------------------
# Bad input names the field


@pytest.mark.parametrize(
    ("make", "field"),
    [
        (lambda: FeedLimits(700.0, 600.0), "upper_feed_rate_mm_min"),
        (lambda: FeedLimits(-1.0, 600.0), "lower_feed_rate_mm_min"),
        (lambda: StepWorkpiece(((10.0, 1.5), (0.0, 3.0))), "segments[1].length_mm"),
        (lambda: KimJeonForceModel(flute_count=0), "flute_count"),
        (lambda: KimJeonForceModel(ks_exponent=0.2), "ks_exponent"),
        (lambda: case1_controller("pid"), "controller"),
        (lambda: CorrectiveConfig(max_spindle_rpm=-5.0), "max_spindle_rpm"),
        (lambda: EdgeLifeConfig(max_passes=0), "max_passes"),
        (lambda: TaiPIGains(kp_mm_min_per_A=float("nan")), "kp_mm_min_per_A"),
    ],
)
def test_bad_configuration_names_the_field(make, field):
    with pytest.raises(InputError) as err:
        make()
    assert err.value.field == field


def test_simulate_refuses_a_force_signal_without_a_calibration():
    setup = MillSetup(process=TaiMill(TAI_END_MILLING), spindle_rpm=10000.0, radial_depth_mm=1.4)
    with pytest.raises(InputError) as err:
        simulate(
            setup,
            StepWorkpiece(((150.0, 0.2),)),
            TaiPIController(FeedLimits(600.0, 1000.0)),
            reference=0.24,
            signal="force_N",
            initial_feed_rate_mm_min=1000.0,
            rng=np.random.default_rng(0),
        )
    assert err.value.field == "signal"
