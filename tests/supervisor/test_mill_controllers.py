"""The inner feed-control loops of the virtual mill (issue 7, part 2), controller by controller:
Tai, Tsai & Li (IEEE Access 2023) Eq. 16, the PI; Kim & Jeon (Precision Engineering 2011)
Table 2, the fuzzy rules; Borangiu et al. (IFAC 2007) Table 1, the corrective actions. The
force models, the plant and the acceptance runs: test_mill_control.py.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from supervisor.virtual.mill import (
    KIM_JEON_FEED_LIMITS,
    FeedLimits,
    MillSetup,
    StepWorkpiece,
    TaiMill,
    simulate,
)
from supervisor.virtual.mill.controllers import (
    LEVELS,
    RULES,
    BorangiuCorrectiveController,
    CorrectiveConfig,
    FuzzyScaling,
    KimJeonFuzzyController,
    TaiPIController,
    TaiPIGains,
    borangiu_increments,
    borangiu_violations,
    fuzzy_output,
    memberships,
    rule,
    tai_pi_gains_for,
)
from supervisor.virtual.mill.controllers.fuzzy_rules import ASYMMETRIC_CELLS, rank_table
from supervisor.virtual.mill.tai_end_milling import TAI_END_MILLING

# --------------------------------------------------------------------------------------------
# Tai et al. PI (Eq. 16)


def _pi_reference_step(gains: TaiPIGains, duration_s: float) -> np.ndarray:
    """Current after a reference step 0.19034 -> 0.24 A on Tai's plane, no lag or noise."""
    setup = MillSetup(process=TaiMill(TAI_END_MILLING), spindle_rpm=10000.0,
                      radial_depth_mm=1.4, sample_period_s=0.02)  # fmt: skip
    run = simulate(
        setup,
        StepWorkpiece(((1000.0, 0.2),)),
        TaiPIController(FeedLimits(100.0, 2000.0), gains),
        reference=0.24,
        signal="spindle_current_A",
        initial_feed_rate_mm_min=600.0,
        rng=np.random.default_rng(0),
        max_time_s=duration_s,
    )
    return np.asarray(run.current_A)


def test_pi_rise_and_settling_times_match_the_papers_design():
    # Incremental reading of Eq. 16 at 50 Hz: the loop gain per sample is K_p·B = 160 ·
    # 1.2416e-4 = 0.019866, so the error shrinks by (1 − 0.019866) per sample:
    #   10-90 % rise: ln 9 / −ln(0.980134) = 2.19722/0.020066 = 109.5 samples = 2.19 s
    #   2 % settling: ln 50 / 0.020066 = 195.0 samples = 3.90 s
    # Tai et al. §III.B designed for "rising time 2 seconds, settling time 4 seconds".
    current = _pi_reference_step(TaiPIGains(), 10.0)
    start, step = 0.24 - 400.0 * TAI_END_MILLING.slope_A_per_mm_min, 400.0 * 1.2416e-4
    progress = (current - start) / step
    t = 0.02 * (np.arange(len(current)) + 1)
    rise = t[np.argmax(progress >= 0.9)] - t[np.argmax(progress >= 0.1)]
    settled = t[np.nonzero(np.abs(progress - 1.0) > 0.02)[0][-1] + 1]
    assert rise == pytest.approx(2.19, abs=0.04)
    assert settled == pytest.approx(3.90, abs=0.06)


def test_pi_without_kp_is_far_slower():
    # With K_p = 0 only Eq. 16's second integral is left: after 10 s the feed has moved by
    # about K_i·Σ S_k ≈ 0.006 · 0.0498 A · 0.02 s · 500²/2 ≈ 0.75 mm/min of the 400 needed.
    current = _pi_reference_step(TaiPIGains(kp_mm_min_per_A=0.0), 10.0)
    progress = (current[-1] - current[0]) / (400.0 * 1.2416e-4)
    assert progress < 0.01


def test_pi_integral_does_not_wind_up_on_a_limit():
    limits = FeedLimits(600.0, 1000.0)
    pi = TaiPIController(limits, TaiPIGains(kp_mm_min_per_A=0.0, ki_mm_min_per_A_s=100.0))
    pi.reset(1000.0, 10000.0)
    for _ in range(1000):  # current 0.01 A below the reference: pushes past the upper limit
        assert pi.step(0.23, 0.24, 0.02) == 1000.0
    # without the freeze Σe·dt would be 0.2 A·s and 100·0.2 = 20 mm/min would hold the limit
    assert pi.step(0.25, 0.24, 0.02) < 1000.0


def test_pi_gains_scale_with_the_plant():
    same = tai_pi_gains_for(TAI_END_MILLING.slope_A_per_mm_min, 0.02)
    assert_allclose([same.kp_mm_min_per_A, same.ki_mm_min_per_A_s], [160.0, 0.006])
    double = tai_pi_gains_for(2.0 * TAI_END_MILLING.slope_A_per_mm_min, 0.04)
    assert_allclose(double.kp_mm_min_per_A, 160.0, rtol=1e-12)  # half per gain, twice per dt


# --------------------------------------------------------------------------------------------
# Kim & Jeon fuzzy controller (Table 2)


def test_rule_table_cells_as_printed():
    # Kim & Jeon Table 2, row NS: NVB NB NM NM NS NVS NVS ZO PS PS PM
    assert RULES[LEVELS.index("NS")] == (
        "NVB", "NB", "NM", "NM", "NS", "NVS", "NVS", "ZO", "PS", "PS", "PM",
    )  # fmt: skip
    assert rule("NVB", "NVB") == "NVB" and rule("PVB", "PVB") == "PVB"
    assert rule("NVB", "PVB") == "ZO" and rule("PVB", "NVB") == "ZO"
    assert rule("ZO", "ZO") == "ZO"
    assert rule("ZO", "NVB") == "NB" and rule("PB", "NM") == "PS"
    assert rule("NB", "NVS") == "NM" and rule("PB", "PVS") == "PB"  # the one asymmetric pair
    assert len(RULES) == 11 and all(len(row) == 11 for row in RULES)


def test_rule_table_symmetry_as_printed():
    ranks = rank_table()
    # antisymmetric, rule(−e, −ce) = −rule(e, ce), in all cells but the pair (NB, NVS)/(PB, PVS)
    assert ASYMMETRIC_CELLS == (("NB", "NVS"),)
    assert ranks[1][4] == -3 and ranks[9][6] == 4
    # non-decreasing along every row and every column
    assert all(row[j] <= row[j + 1] for row in ranks for j in range(10))
    assert all(ranks[i][j] <= ranks[i + 1][j] for i in range(10) for j in range(11))
    # a change that cancels the error (CĒ = −Ē) asks for no change of feed
    assert all(RULES[i][10 - i] == "ZO" for i in range(11))
    with pytest.raises(ValueError, match="error_level"):
        rule("PX", "ZO")


@settings(max_examples=200, deadline=None)
@given(value=st.floats(-2.0, 2.0), step=st.floats(0.01, 0.5), deadband=st.floats(0.0, 0.1))
def test_memberships_partition_unity(value, step, deadband):
    degrees = memberships(value, step, deadband)
    assert sum(degrees) == pytest.approx(1.0, abs=1e-12)
    assert sum(d > 0 for d in degrees) <= 2 and min(degrees) >= 0.0


def test_memberships_deadband_and_shoulders():
    # Ē sets: ZO flat on |Ē| <= 0.02, PVS centred at 0.02 + 0.05 = 0.07, PVB from 0.27
    assert memberships(0.019, 0.05, 0.02)[5] == 1.0
    assert_allclose(memberships(0.045, 0.05, 0.02)[5:7], [0.5, 0.5])
    assert memberships(0.07, 0.05, 0.02)[6] == 1.0
    assert memberships(5.0, 0.05, 0.02)[10] == 1.0 and memberships(-5.0, 0.05, 0.02)[0] == 1.0


def test_fuzzy_output_hand_computed():
    s = FuzzyScaling()
    assert fuzzy_output(0.0, 0.0, s) == 0.0
    assert fuzzy_output(0.015, 0.0, s) == 0.0  # inside the deadband
    # Ē = 0.12 is PS (0.02 + 2·0.05), CĒ = 0 is ZO: rule(PS, ZO) = PVS -> 1 · 0.2 = 0.2
    assert_allclose(fuzzy_output(0.12, 0.0, s), 0.2)
    # Ē = 0.095 is half PVS, half PS; CĒ = −0.01 half NVS, half ZO:
    #   (PVS,NVS)=ZO 0, (PVS,ZO)=PVS 0.2, (PS,NVS)=PVS 0.2, (PS,ZO)=PVS 0.2 -> 0.25·0.6 = 0.15
    assert_allclose(fuzzy_output(0.095, -0.01, s), 0.15)
    assert fuzzy_output(-1.0, -1.0, s) == -1.0 and fuzzy_output(1.0, 1.0, s) == 1.0


@settings(max_examples=200, deadline=None)
@given(e=st.floats(-0.5, 0.5), ce=st.floats(-0.2, 0.2), de=st.floats(0.0, 0.3))
def test_fuzzy_output_is_monotone_in_the_error_and_its_change(e, ce, de):
    s = FuzzyScaling()
    out = fuzzy_output(e, ce, s)
    assert -1.0 <= out <= 1.0
    assert fuzzy_output(e + de, ce, s) >= out - 1e-12
    assert fuzzy_output(e, ce + de, s) >= out - 1e-12


def test_fuzzy_holds_the_feed_inside_the_deadband():
    # 157 N is Ē = 3/160 = 0.019, inside the ±2 % deadband, and CĒ = 0: rule(ZO, ZO) = ZO
    flc = KimJeonFuzzyController(KIM_JEON_FEED_LIMITS)
    flc.reset(100.0, 1500.0)
    assert flc.step(157.0, 160.0, 0.04) == 100.0
    assert flc.step(157.0, 160.0, 0.04) == 100.0
    # 240 N: Ē = −0.5 is NVB, CĒ = 0 is ZO: rule(NVB, ZO) = NVB = −1 -> feed − K_v = 96
    flc.reset(100.0, 1500.0)
    assert flc.step(240.0, 160.0, 0.04) == pytest.approx(96.0)
    # 300 N next: CĒ = −60/160 is NVB too: rule(NVB, NVB) = NVB -> 92
    assert flc.step(300.0, 160.0, 0.04) == pytest.approx(92.0)


# --------------------------------------------------------------------------------------------
# Borangiu et al. corrective actions (Table 1)


@pytest.mark.parametrize(
    ("violations", "expected"),
    [
        ((), (1, 0)),  # inside the allowable area: w <- w + Δw
        (("R1_max_chip_load",), (-1, 1)),
        (("R2_max_power",), (-1, -1)),
        (("R3_unloaded",), (1, -1)),
        (("R4_speed_above_max",), (0, -1)),
        (("R4_speed_below_min",), (0, 1)),
        (("R5_min_feed",), (1, 0)),
        (("R1_max_chip_load", "R2_max_power"), (-1, 0)),  # NINC and NDEC cancel
        (("R1_max_chip_load", "R5_min_feed"), (1, 1)),  # WINC = WDEC: w + Δw as printed
    ],
)
def test_table_1_increments(violations, expected):
    assert borangiu_increments(violations) == expected


def test_violations_of_load_power_pitch_and_speed():
    limits = FeedLimits(20.0, 240.0)
    config = CorrectiveConfig(max_power_kW=0.1, max_spindle_rpm=1400.0, min_feed_per_rev_mm=0.1)
    # 160 N at 1500 rpm, D = 10: v = 47.124 m/min, P = 160·47.124/60000 = 0.12566 kW > 0.1;
    # pitch feed 100/1500 = 0.0667 mm/rev < 0.1; speed above 1400
    found = borangiu_violations(170.0, 160.0, 100.0, 1500.0, limits, config)
    assert found == ("R1_max_chip_load", "R2_max_power", "R3_unloaded", "R4_speed_above_max")
    assert borangiu_violations(150.0, 160.0, 100.0, 1000.0, limits, CorrectiveConfig()) == ()


def test_corrective_controller_steps_feed_and_speed():
    config = CorrectiveConfig(feed_step_mm_min=2.0, spindle_step_rpm=10.0, max_spindle_rpm=1600)
    ctl = BorangiuCorrectiveController(FeedLimits(20.0, 240.0), config)
    ctl.reset(100.0, 1500.0)
    assert ctl.step(150.0, 160.0, 0.04) == 102.0 and ctl.spindle_rpm == 1500.0
    assert ctl.step(170.0, 160.0, 0.04) == 100.0 and ctl.spindle_rpm == 1510.0  # R1
