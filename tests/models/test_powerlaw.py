"""Power-law models and first-order (GUM) propagation."""

from __future__ import annotations

import math

import pytest
from numpy.testing import assert_allclose

from models.errors import InputError
from models.powerlaw import PowerLawModel, relative_band


def test_band_of_k_alone_is_proportional():
    # Ivester & Heigel Table 5 step 1 row R: 1867 ± 131 N, i.e. F · 150/2130
    model = PowerLawModel("force_N", 2130, 150, {"depth_mm": 0.888, "feed_mm_rev": 0.783})
    p = model.predict({"depth_mm": 3.0, "feed_mm_rev": 0.32})
    assert_allclose(p.band / p.value, 150 / 2130)


def test_exponent_goes_inside_the_square():
    # GUM: (ΔY/Y)² = (ΔK/K)² + (e·Δx/x)²; Eq. 7 as printed would give (ΔK/K)² + e·(Δx/x)².
    rel = relative_band(0.1, {"feed_mm_rev": 2.0}, {"feed_mm_rev": 0.05})
    assert_allclose(rel, math.sqrt(0.1**2 + (2.0 * 0.05) ** 2))  # 0.14142
    assert not math.isclose(rel, math.sqrt(0.1**2 + 2.0 * 0.05**2))  # misprint: 0.12247


def test_tool_life_eq8_hand_computed():
    # Ivester & Heigel Eq. 8: mr = 9e8 d^0.488 f^0.045 v^-0.821 w^1.241, ΔK = 4.7e8 (Eq. 9)
    model = PowerLawModel(
        "tool_life_mm3",
        9e8,
        4.7e8,
        {"depth_mm": 0.488, "feed_mm_rev": 0.045, "speed_m_min": -0.821, "flank_wear_mm": 1.241},
    )
    point = {"depth_mm": 3.0, "feed_mm_rev": 0.32, "speed_m_min": 200.0, "flank_wear_mm": 0.3}
    expected = 9e8 * 3.0**0.488 * 0.32**0.045 * 200.0**-0.821 * 0.3**1.241  # 4.234e6 mm³
    p = model.predict(point)
    assert_allclose(p.value, expected)
    assert_allclose(p.value, 4.234e6, rtol=1e-3)
    assert_allclose(p.lower, expected * (1 - 4.7e8 / 9e8))


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"K": 0.0, "dK": 1.0}, "force_N.K"),
        ({"K": 10.0, "dK": -1.0}, "force_N.dK"),
        ({"K": float("nan"), "dK": 1.0}, "force_N.K"),
    ],
)
def test_bad_coefficients_are_refused(kwargs, field):
    with pytest.raises(InputError) as err:
        PowerLawModel("force_N", exponents={}, **kwargs)
    assert err.value.field == field


def test_unknown_quantity_is_refused():
    with pytest.raises(InputError, match="unknown"):
        PowerLawModel("forse_N", 1.0, 0.0)


def test_non_positive_input_is_refused():
    model = PowerLawModel("force_N", 2130, 150, {"depth_mm": 0.888})
    with pytest.raises(InputError) as err:
        model.predict({"depth_mm": -1.0})
    assert err.value.field == "depth_mm" and err.value.value == -1.0
