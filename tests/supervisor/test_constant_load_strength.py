"""Constant-load milling (Tai, Tsai & Li 2023, §II.F, §III.A, §III.C): the robust reference
current at the tool's strength, the tool-change rule, and the setup's invariants (Hypothesis).
The setup itself, its CLI and its refusals: test_constant_load.py.
"""

from __future__ import annotations

import json
import math

import pytest
from constant_load_support import TESTS_CSV, _csv_tests, _exact, _run
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from models.errors import InputError, ModelDomainError
from models.sensors import LinearCurrentCalibration, linear_current_force_N
from supervisor.constant_load import (
    ForceLimit,
    constant_load_setup,
    strength_current_A,
    tool_change_due,
)

# --------------------------------------------------------------------------------------------
# the robust reference current: the upper force band at the tool's strength

#: F = −10 N + 500 N/A · I, residual scatter 2 N, no parameter uncertainty.
SIMPLE_FORCE = LinearCurrentCalibration(
    offset_N=-10.0, slope_N_per_A=500.0, residual_sd_N=2.0, source="test"
)


def test_strength_current_by_hand():
    # a + b·I + 2·s = F_s  ->  I = (100 + 10 − 2·2)/500 = 0.212 A
    assert_allclose(strength_current_A(ForceLimit(100.0, SIMPLE_FORCE)), 0.212, rtol=1e-12)
    # with a current reading uncertainty 0.004 A: u_F = sqrt(2² + (500·0.004)²) = 2.828 N
    # I = (110 − 2·2.8284)/500 = 0.208686 A
    with_u = strength_current_A(ForceLimit(100.0, SIMPLE_FORCE, u_current_A=0.004))
    assert_allclose(with_u, (110 - 2 * math.sqrt(8.0)) / 500, rtol=1e-12)


def test_strength_current_with_covariance_meets_the_band_exactly():
    cal = LinearCurrentCalibration(
        offset_N=-10.0, slope_N_per_A=500.0, u_offset_N=1.5, u_slope_N_per_A=8.0,
        corr_offset_slope=-0.8, residual_sd_N=2.0, source="test",
    )  # fmt: skip
    current = strength_current_A(ForceLimit(100.0, cal))

    def upper_band(i):  # written out: u_F² = u_a² + 2I·ρ·u_a·u_b + I²u_b² + s²
        var = 1.5**2 + 2 * i * (-0.8 * 1.5 * 8.0) + i * i * 8.0**2 + 2.0**2
        return -10.0 + 500.0 * i + 2 * math.sqrt(var)

    assert_allclose(upper_band(current), 100.0, rtol=1e-12)
    assert upper_band(current * 1.001) > 100.0
    assert 0.20 < current < 0.212  # parameter uncertainty costs current against 0.212 A


def test_strength_governs_the_reference_current():
    feeds, currents, wears = _exact()
    setup = constant_load_setup(feeds, currents, wears, strength=ForceLimit(100.0, SIMPLE_FORCE))
    # min(0.212 A from the strength, 0.85 × 0.28 = 0.238 A) = 0.212 A
    assert setup.governed_by == "strength"
    assert_allclose(setup.reference_current_A, 0.212, rtol=1e-12)
    assert_allclose(setup.strength_current_A, 0.212, rtol=1e-12)
    # upper (0.212 − 0.1)/1.4e-4 = 800 mm/min; lower (0.112 − 0.044)/1.4e-4 = 485.714 mm/min
    assert_allclose(setup.upper.feed_rate_mm_min, 800.0, rtol=1e-9)
    assert_allclose(setup.lower.feed_rate_mm_min, 485.714286, rtol=1e-7)
    force = linear_current_force_N(SIMPLE_FORCE, setup.reference_current_A)
    assert force.value + 2 * force.uncertainty == pytest.approx(100.0)


def test_safety_factor_governs_when_the_tool_is_strong():
    feeds, currents, wears = _exact()
    setup = constant_load_setup(feeds, currents, wears, strength=ForceLimit(200.0, SIMPLE_FORCE))
    # strength current (200 + 10 − 4)/500 = 0.412 A > 0.238 A
    assert setup.governed_by == "safety_factor"
    assert_allclose(setup.strength_current_A, 0.412, rtol=1e-12)
    assert_allclose(setup.reference_current_A, 0.238, rtol=1e-12)


def test_cli_strength_with_a_calibration_file(tmp_path):
    cal = tmp_path / "force.toml"
    cal.write_text(
        'kind = "linear_current"\nsource = "test"\noffset_N = -10.0\nslope_N_per_A = 500.0\n'
        "residual_sd_N = 2.0\n",
        encoding="utf-8",
    )
    code, out, err = _run(
        "setup", TESTS_CSV, "--json", "--strength-force-N", "100", "--force-calibration", cal
    )
    assert code == 0, err
    data = json.loads(out)
    assert data["governed_by"] == "strength"
    assert data["reference_current_A"] == pytest.approx(0.212, rel=1e-12)  # (110 − 4)/500


def test_strength_refusals():
    weak = LinearCurrentCalibration(offset_N=0.0, slope_N_per_A=10.0, u_slope_N_per_A=6.0,
                                    source="test")  # fmt: skip
    with pytest.raises(InputError) as err:
        strength_current_A(ForceLimit(100.0, weak))
    assert err.value.field == "calibration.u_slope_N_per_A"
    offset = LinearCurrentCalibration(offset_N=50.0, slope_N_per_A=500.0, residual_sd_N=2.0,
                                      source="test")  # fmt: skip
    with pytest.raises(InputError) as err:  # 50 + 2·2 = 54 N > 40 N at zero current
        strength_current_A(ForceLimit(40.0, offset))
    assert err.value.field == "strength_force_N"
    with pytest.raises(InputError) as err:
        ForceLimit(-1.0, SIMPLE_FORCE)
    assert err.value.field == "strength_force_N"


# --------------------------------------------------------------------------------------------
# the tool-change rule (Tai §III.C: change the tool when the feed command touches the lower limit)


@pytest.fixture(scope="module")
def exact_setup():
    return constant_load_setup(*_exact())


def test_tool_change_at_above_and_below_the_lower_limit(exact_setup):
    lower = 671.428571429  # hand-computed above
    at = tool_change_due(exact_setup, feed_rate_mm_min=lower)
    assert at.due and "change the tool" in at.reason
    assert_allclose(at.flank_wear_mm, 0.220, atol=1e-6)  # Eq. 15 solved for VB at the limit
    above = tool_change_due(exact_setup, feed_rate_mm_min=700.0)
    assert not above.due and "keep cutting" in above.reason
    assert_allclose(above.margin_mm_min, 700.0 - lower, rtol=1e-9)
    # (0.238 − 0.1 − 1.4e-4·700)/0.2 = 0.2 mm
    assert_allclose(above.flank_wear_mm, 0.200, rtol=1e-9)
    below = tool_change_due(exact_setup, feed_rate_mm_min=650.0)
    assert below.due and below.margin_mm_min < 0
    assert not tool_change_due(exact_setup, feed_rate_mm_min=672.0).due
    assert tool_change_due(exact_setup, feed_rate_mm_min=672.0, tolerance_mm_min=1.0).due


def test_tool_change_from_the_feed_override(exact_setup):
    # override percent of the programmed feed; the program runs at the upper limit by default:
    # 985.714 × 68.1 % = 671.271 mm/min <= 671.429 -> due; 68.2 % -> 672.257 mm/min -> not
    assert tool_change_due(exact_setup, feed_override_percent=68.1).due
    decision = tool_change_due(exact_setup, feed_override_percent=68.2)
    assert not decision.due
    assert_allclose(decision.feed_rate_mm_min, 985.714286 * 0.682, rtol=1e-8)
    # programmed at 800 mm/min: 84 % = 672 mm/min -> not due; 83.9 % = 671.2 -> due
    assert not tool_change_due(
        exact_setup, feed_override_percent=84, programmed_feed_rate_mm_min=800
    ).due
    assert tool_change_due(
        exact_setup, feed_override_percent=83.9, programmed_feed_rate_mm_min=800
    ).due


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({}, "feed_rate_mm_min"),
        ({"feed_rate_mm_min": 600.0, "feed_override_percent": 60.0}, "feed_rate_mm_min"),
        ({"feed_rate_mm_min": 0.0}, "feed_rate_mm_min"),
        ({"feed_override_percent": -5.0}, "feed_override_percent"),
        ({"feed_rate_mm_min": 600.0, "programmed_feed_rate_mm_min": 800.0},
         "programmed_feed_rate_mm_min"),
    ],
)  # fmt: skip
def test_tool_change_refuses_bad_input(exact_setup, kwargs, field):
    with pytest.raises(InputError) as err:
        tool_change_due(exact_setup, **kwargs)
    assert err.value.field == field


# --------------------------------------------------------------------------------------------
# invariants


@settings(max_examples=100, deadline=None)
@given(
    a=st.floats(0.05, 0.2),
    b=st.floats(5e-5, 3e-4),
    k1=st.floats(0.02, 0.6),
    eta=st.floats(0.5, 1.0),
    worn_end=st.floats(0.05, 0.3),
)
def test_lower_limit_is_below_the_upper_whenever_k1_is_positive(a, b, k1, eta, worn_end):
    cuts = [(600, 0.0), (800, 0.0), (1000, 0.0), (600, 0.1), (800, 0.2), (1000, 0.15)]
    data = _exact(cuts, a, b, k1)
    i_ref = eta * max(data[1])
    interval = (0.0, worn_end)
    if i_ref - a - k1 * worn_end <= 1e-6:  # the worn tool alone draws the reference current
        with pytest.raises(ModelDomainError):
            constant_load_setup(*data, safety_factor=eta, wear_interval_mm=interval)
        return
    setup = constant_load_setup(*data, safety_factor=eta, wear_interval_mm=interval)
    assert setup.lower.feed_rate_mm_min < setup.upper.feed_rate_mm_min
    assert_allclose(setup.upper.feed_rate_mm_min, (i_ref - a) / b, rtol=1e-6)
    assert_allclose(setup.lower.feed_rate_mm_min, (i_ref - a - k1 * worn_end) / b,
                    rtol=1e-6, atol=1e-6)  # fmt: skip


@settings(max_examples=60, deadline=None)
@given(eta1=st.floats(0.6, 1.0), eta2=st.floats(0.6, 1.0))
def test_a_larger_safety_factor_never_lowers_the_upper_limit(eta1, eta2):
    lo, hi = sorted((eta1, eta2))
    tests = _csv_tests()
    first = constant_load_setup(*tests, safety_factor=lo)
    second = constant_load_setup(*tests, safety_factor=hi)
    assert first.reference_current_A <= second.reference_current_A
    assert first.upper.feed_rate_mm_min <= second.upper.feed_rate_mm_min


@settings(max_examples=100, deadline=None)
@given(
    offset=st.floats(-50.0, 10.0),
    slope=st.floats(100.0, 1000.0),
    u_offset=st.floats(0.0, 3.0),
    u_slope_rel=st.floats(0.0, 0.2),
    corr=st.floats(-0.99, 0.99),
    s=st.floats(0.0, 5.0),
    u_current=st.floats(0.0, 0.01),
    strength=st.floats(60.0, 300.0),
)
def test_strength_current_puts_the_upper_band_on_the_strength(
    offset, slope, u_offset, u_slope_rel, corr, s, u_current, strength
):
    cal = LinearCurrentCalibration(
        offset_N=offset, slope_N_per_A=slope, u_offset_N=u_offset,
        u_slope_N_per_A=u_slope_rel * slope, corr_offset_slope=corr, residual_sd_N=s,
        source="test",
    )  # fmt: skip
    current = strength_current_A(ForceLimit(strength, cal, u_current_A=u_current))
    at = linear_current_force_N(cal, current, u_current)
    assert at.value + 2 * at.uncertainty == pytest.approx(strength, rel=1e-9)
    assert at.value <= strength * (1 + 1e-12)  # the nominal force is within the band edge
