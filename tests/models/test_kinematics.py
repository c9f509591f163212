"""Turning and milling kinematics, hand-computed."""

from __future__ import annotations

import math

from numpy.testing import assert_allclose

from models import kinematics


def test_turning_rpm_and_rate():
    # n = 1000·200/(π·60) = 1061.03 rpm; MRR = 3.0·0.32·200 = 192 cm³/min (Ivester Eq. 10)
    assert_allclose(kinematics.turning_spindle_rpm(200, 60), 1061.0330, rtol=1e-6)
    assert_allclose(kinematics.turning_mrr_cm3_min(3.0, 0.32, 200), 192.0)


def test_milling_rate():
    # n = 1000·150/(π·10) = 4774.65 rpm; vf = 0.1·4·n = 1909.86 mm/min; Q = 2·5·vf/1000
    assert_allclose(kinematics.milling_mrr_cm3_min(2, 5, 0.1, 150, 10, 4), 19.0986, rtol=1e-5)
    vf = kinematics.feed_rate_monomial("milling").evaluate(
        {"feed_per_tooth_mm": 0.1, "flute_count": 4, "speed_m_min": 150, "tool_diameter_mm": 10}
    )
    assert_allclose(vf, 0.1 * 4 * 150_000 / (math.pi * 10))


def test_power_and_torque():
    # 2000 N at 200 m/min: 2000·200/60000 = 6.667 kW; at Ø60 mm: 2000·0.030 = 60 N·m (Eq. 3)
    assert_allclose(kinematics.cutting_power_kW(2000, 200), 6.6667, rtol=1e-4)
    assert_allclose(kinematics.spindle_torque_Nm(2000, 60), 60.0)
