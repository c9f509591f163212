"""The packaged catalogue holds Ivester & Heigel Tables 2-3 and Eq. 8 with provenance."""

from __future__ import annotations

import pytest

from models.catalogue import catalogue, get_tool
from models.errors import InputError

# insert: (force K, dK, a, b, c) Table 2; (roughness K, dK, a, b, c) Table 3
TABLES = {
    "CNMG432RN": ((2130, 150, 0.888, 0.783, -0.0395), (54, 14, -0.006, 1.284, -0.261)),
    "CPGM32505": ((3855, 380, 0.976, 0.779, -0.196), (21, 8, -0.086, 1.123, -0.002)),
    "VCMR331": ((343, 105, 0.942, 0.729, 0.219), (23, 3.7, 0.151, 1.225, 0.010)),
    "VPGR3305": ((343, 105, 0.942, 0.729, 0.219), (40.5, 14, 0.033, 1.095, -0.034)),
}


@pytest.mark.parametrize("insert", sorted(TABLES))
def test_tables_2_and_3(insert):
    tool = get_tool(insert)
    for quantity, row in zip(("force_N", "roughness_um"), TABLES[insert], strict=True):
        model = tool.models[quantity]
        exps = model.exponents
        got = (model.K, model.dK, exps["depth_mm"], exps["feed_mm_rev"], exps["speed_m_min"])
        assert got == row
        assert model.source.startswith("Ivester & Heigel") and "Table" in model.reference
    assert tool.process == "turning" and "1045" in tool.material


def test_tool_life_eq8():
    model = get_tool("CNMG432RN").models["tool_life_mm3"]
    assert (model.K, model.dK) == (9e8, 4.7e8)  # Ivester & Heigel Eq. 8, ΔK of Eq. 9
    assert model.exponents == {
        "depth_mm": 0.488,
        "feed_mm_rev": 0.045,
        "speed_m_min": -0.821,
        "flank_wear_mm": 1.241,
    }
    assert sorted(catalogue()) == sorted(TABLES)


def test_unknown_tool_names_the_known_ones():
    with pytest.raises(InputError, match="CNMG432RN") as err:
        get_tool("NOPE")
    assert err.value.value == "NOPE"
