"""Fitting a tool-life model (``models.fit``, ``rcb fit``) on the NASA Ames / UC Berkeley milling
wear labels (MIT, pyphm; ``tests/data/ATTRIBUTION.md``): the time to VB = 0.3 mm per case, the
fit per material with its measured figures, and the pooled fit that explains little.
"""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest
from fit_support import NASA_CSV, life_fit, run, time_to_wear, tool_life_table

# --------------------------------------------------------------------------------------------
# (d) NASA milling: tool life to VB = 0.3 mm


def test_time_to_wear_interpolates_and_skips_cases_that_never_reach_it() -> None:
    table, never = time_to_wear(pd.read_csv(NASA_CSV))
    assert never == [6]  # case 6 (steel, 1.5 mm, 0.25 mm/rev) has one label: VB 0 at t 0
    assert len(table) == 15
    times = dict(zip(table["case"], table["time_min"], strict=True))
    assert times[1] == pytest.approx(29 + 3 * (0.30 - 0.29) / (0.38 - 0.29))  # 0.29@29, 0.38@32
    assert times[8] == 6.0  # VB = 0.30 exactly at t = 6
    assert times[11] == pytest.approx(51 + 6 * (0.30 - 0.26) / (0.31 - 0.26))


#: Tool life T [min] = K · ap^a · fz^b, per material (ap = DOC [mm], fz = feed/6 [mm]).
#: Measured: cast iron n = 8: K 27.82, a −1.032 ± 0.182, b −0.097 ± 0.182, R² 0.866, s 0.179,
#: range ΔK/K 0.259, 2s ΔK/K 0.430 (coverage 1.0); steel n = 7: K 1.202, a −0.854 ± 0.304,
#: b −0.691 ± 0.304, R² 0.796, s 0.272, range ΔK/K 0.312, 2s ΔK/K 0.722 (coverage 1.0).
MEASURED_LIFE: dict[int, dict[str, float]] = {
    1: {"n": 8, "K": 27.82, "a": -1.0318, "b": -0.0968, "r2": 0.8659, "s": 0.1788,
        "range": 0.2595, "two_s": 0.4299},
    2: {"n": 7, "K": 1.2016, "a": -0.8543, "b": -0.6906, "r2": 0.7965, "s": 0.2717,
        "range": 0.3115, "two_s": 0.7220},
}  # fmt: skip


@pytest.mark.parametrize("material", [1, 2])
def test_tool_life_fit_per_material(material: int) -> None:
    table = tool_life_table()
    result = life_fit(table[table["material"] == material])
    expected = MEASURED_LIFE[material]
    assert result.n == expected["n"]
    assert result.K == pytest.approx(expected["K"], rel=1e-3)
    assert result.exponents["axial_depth_mm"] == pytest.approx(expected["a"], abs=1e-4)
    assert result.exponents["feed_per_tooth_mm"] == pytest.approx(expected["b"], abs=1e-4)
    assert (result.r2, result.s) == pytest.approx((expected["r2"], expected["s"]), abs=1e-4)
    assert result.dK / result.K == pytest.approx(expected["range"], abs=1e-4)
    two_s = result.with_band("2s")
    assert two_s.dK / two_s.K == pytest.approx(expected["two_s"], abs=1e-4)
    # so few points (dof 5 and 4) that the largest residual is only 1.3 s: ±2s is wider than
    # the range of the points and covers them all
    assert two_s.coverage == 1.0 and two_s.dK > result.dK
    # tool life falls with depth of cut: significantly for cast iron
    assert result.exponents["axial_depth_mm"] < 0


def test_tool_life_pooled_over_materials_explains_little() -> None:
    """One model for cast iron and steel: R² 0.17, s 0.85 (against 0.87/0.80 and 0.18/0.27)."""
    pooled = life_fit(tool_life_table())
    assert pooled.n == 15
    assert (pooled.r2, pooled.s) == pytest.approx((0.1715, 0.8477), abs=1e-4)
    assert pooled.r2 < 0.25 and pooled.s > 3 * MEASURED_LIFE[2]["s"]


def test_tool_life_through_the_cli(tmp_path: Path) -> None:
    csv = tmp_path / "tool_life.csv"
    tool_life_table().to_csv(csv, index=False)
    args = [
        csv,
        "--process=milling",
        "--response=time_min",
        "--var=axial_depth_mm=DOC",
        "--var=feed_per_tooth_mm=fz_mm",
        "--where=material=1",
        "--band=2s",
        "--json",
    ]
    code, out, err = run(args)
    assert code == 0, err
    data = json.loads(out)
    direct = life_fit(tool_life_table().query("material == 1"), band="2s")
    assert data["n"] == 8 and data["where"] == ["material=1"]
    assert data["K"] == pytest.approx(direct.K, rel=1e-12)
    assert data["exponents"] == pytest.approx(dict(direct.exponents), rel=1e-12)
    assert data["coverage"] == 1.0 and data["k"] == 2.0
