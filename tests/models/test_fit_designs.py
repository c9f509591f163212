"""Fitting power laws (``models.fit``): degenerate designs are refused, naming the column and row,
and on synthetic data (Hypothesis) the fit recovers the law it was made from.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from fit_support import ra, tool_life_table, turning_fit
from hypothesis import given, settings
from hypothesis import strategies as st

from models.errors import InputError
from models.fit import fit_power_law

# --------------------------------------------------------------------------------------------
# (e) degenerate designs are refused, naming the column


def _error(func: Any, *args: Any, **kwargs: Any) -> InputError:
    with pytest.raises(InputError) as info:
        func(*args, **kwargs)
    return info.value


def test_constant_column_is_refused() -> None:
    table = tool_life_table()
    err = _error(
        fit_power_law,
        table["time_min"].to_numpy(),
        {"axial_depth_mm": table["DOC"].to_numpy(), "speed_m_min": np.full(len(table), 200.0)},
    )
    assert err.field == "speed_m_min" and err.value == 200.0 and "constant" in err.reason
    # fixing it (here at 0: Taylor's speed exponent cannot be fitted at one speed) is accepted
    result = fit_power_law(
        table["time_min"].to_numpy(),
        {"axial_depth_mm": table["DOC"].to_numpy(), "speed_m_min": np.full(len(table), 200.0)},
        fixed={"speed_m_min": 0.0},
    )
    assert result.exponents["speed_m_min"] == 0.0


def test_collinear_columns_are_refused_with_their_relation() -> None:
    table = ra("New")
    err = _error(
        fit_power_law,
        table["Ra"].to_numpy(),
        {
            "depth_mm": table["d"].to_numpy(),
            "feed_mm_rev": table["f"].to_numpy(),
            "speed_m_min": 3.0 * table["d"].to_numpy() ** 2 * table["f"].to_numpy(),
        },
        labels={"depth_mm": "d", "feed_mm_rev": "f", "speed_m_min": "Vc2"},
    )
    assert err.field == "Vc2"
    assert "collinear with d (depth_mm), f (feed_mm_rev)" in err.reason
    assert err.value == "ln speed_m_min = 1.099 + 2·ln depth_mm + 1·ln feed_mm_rev"


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_too_few_points_are_refused(n: int) -> None:
    table = ra("New").iloc[[0, 1, 2, 5]].iloc[:n]  # four distinct design points
    err = _error(turning_fit, table)
    assert err.field == "n" and err.value == n
    assert (
        "need at least 5" in err.reason and "ln_K, depth_mm, feed_mm_rev, speed_m_min" in err.reason
    )


@pytest.mark.parametrize(
    ("value", "reason"),
    [(0.0, "greater than 0"), (-1.5, "greater than 0"), (math.nan, "finite"), (math.inf, "finite")],
)
def test_values_without_a_logarithm_are_refused_naming_row_and_column(
    value: float, reason: str
) -> None:
    y = np.array([1.0, 2.0, 3.0, 4.0, 5.0])
    x = np.array([1.0, 2.0, 4.0, 8.0, 16.0])
    bad = x.copy()
    bad[3] = value
    err = _error(fit_power_law, y, {"feed_mm_rev": bad}, labels={"feed_mm_rev": "f"})
    assert err.field == "f[3]" and reason in err.reason
    assert err.value == value or (math.isnan(err.value) and math.isnan(value))
    err = _error(
        fit_power_law, np.where(x == 4.0, value, y), {"feed_mm_rev": x}, rows=list("abcde")
    )
    assert err.field == "response[c]"


def test_other_bad_arguments_are_refused() -> None:
    y, x = [1.0, 2.0, 3.0], {"depth_mm": [1.0, 2.0, 3.0]}
    assert _error(fit_power_law, y, x, band="3s").field == "band"
    assert _error(fit_power_law, y, x, band="2s", k=0.0).field == "k"
    assert _error(fit_power_law, y, {"depth_mm": [1.0, 2.0]}).field == "depth_mm"
    assert _error(fit_power_law, y, x, fixed={"speed_m_min": 1.0}).field == "fixed.speed_m_min"
    assert _error(fit_power_law, y, x, fixed={"depth_mm": math.nan}).field == "fixed.depth_mm"


# --------------------------------------------------------------------------------------------
# (f) synthetic data: the fit recovers the law it was made from


NAMES = ("depth_mm", "feed_mm_rev", "speed_m_min")


@settings(max_examples=60, deadline=None)
@given(
    ln_K=st.floats(-4.0, 9.0),
    exponents=st.lists(st.floats(-2.0, 2.0), min_size=1, max_size=3),
    n=st.integers(12, 60),
    noise=st.sampled_from([0.0, 1e-6, 1e-4]),
    fix_first=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)
def test_recovers_a_synthetic_power_law(
    ln_K: float, exponents: list[float], n: int, noise: float, fix_first: bool, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    names = NAMES[: len(exponents)]
    logs = {}
    for name in names:
        low = rng.uniform(-3.0, 5.0)
        logs[name] = rng.uniform(low, low + rng.uniform(1.0, 3.0), n)
    ln_y = ln_K + sum(e * logs[name] for e, name in zip(exponents, names, strict=True))
    y = np.exp(ln_y + noise * rng.standard_normal(n))
    fixed = {names[0]: exponents[0]} if fix_first else {}
    x = {name: np.exp(v) for name, v in logs.items()}

    result = fit_power_law(y, x, fixed=fixed)

    assert result.coverage == 1.0
    assert math.log(result.K) == pytest.approx(ln_K, abs=0.02)
    assert list(result.exponents.values()) == pytest.approx(exponents, abs=0.01)
    if noise > 0:  # the reported standard errors are the right size
        truth = {"ln_K": ln_K, **dict(zip(names, exponents, strict=True))}
        estimate = {"ln_K": math.log(result.K), **result.exponents}
        for param in result.parameters:
            assert abs(estimate[param] - truth[param]) <= 10 * result.stderr[param] + 1e-12
    # every point lies inside the range band of the model built from the fit
    model = result.to_model("force_N")
    for j in range(n):
        pred = model.predict({name: float(x[name][j]) for name in names})
        assert abs(y[j] - pred.value) <= pred.band * (1 + 1e-9) + 1e-12 * pred.value
    two_s = result.with_band("2s")
    assert two_s.dK == pytest.approx(result.K * math.expm1(2 * result.s))
    assert 0.0 <= two_s.coverage <= 1.0
