"""The constant-load part of a milling setpoint and the tool-change rule, hand-computed."""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from models.errors import InputError
from models.sensors import TaiCurrentFeedCalibration
from supervisor.constant_load.reported_tool_changes import tool_change
from supervisor.constant_load.setpoint import (
    ConstantLoadConfig,
    constant_load_setpoint,
    setup_of,
)
from supervisor.inputs.plan import plan_from_mapping
from supervisor.optimize.optimizer import optimize_plan

ROOT = Path(__file__).resolve().parents[2]
PLAN = tomllib.loads((ROOT / "examples" / "tai_constant_load_part.toml").read_text())
# an exact plane (no scatter): I = 0.1 + 1.4e-4 f + 0.2 VB
CAL = TaiCurrentFeedCalibration(0.1, 1.4e-4, 0.2, source="test")
SETUP = setup_of(ConstantLoadConfig("cal", 0.28), CAL)


def test_limits_from_an_exact_plane():
    # I_ref = 0.85 × 0.28 = 0.238 A; Eq. 13: (0.238 − 0.1)/1.4e-4 = 985.714 mm/min;
    # Eq. 15 at 220 µm: 985.714 − (0.2/1.4e-4)·0.22 = 985.714 − 314.286 = 671.429 mm/min
    assert SETUP.reference_current_A == pytest.approx(0.238)
    assert SETUP.upper.feed_rate_mm_min == pytest.approx(985.714, abs=1e-3)
    assert SETUP.lower.feed_rate_mm_min == pytest.approx(671.429, abs=1e-3)


def test_the_programmed_feed_caps_the_upper_limit():
    below = constant_load_setpoint(SETUP, 800.0)
    assert below.feed_rate_upper_mm_min == 800.0 and below.upper_governed_by == "setpoint"
    above = constant_load_setpoint(SETUP, 1200.0)
    assert above.feed_rate_upper_mm_min == pytest.approx(985.714, abs=1e-3)
    assert above.upper_governed_by == "current"
    # programmed at or below the lower limit: constant feed, change edges by count
    slow = constant_load_setpoint(SETUP, 500.0)
    assert slow.feed_rate_upper_mm_min == slow.feed_rate_lower_mm_min == 500.0
    assert slow.tool_change_by_feed is False
    assert tool_change("op", slow, 50.0).due is False


def test_tool_change_at_the_lower_limit():
    sp = constant_load_setpoint(SETUP, 800.0)
    at = 100.0 * 671.4285714285714 / 800.0  # 83.93 %
    assert tool_change("op", sp, at).due is True
    assert tool_change("op", sp, at - 1.0).due is True
    assert tool_change("op", sp, at + 0.01).due is False
    assert tool_change("op", sp, 100.0).commanded_feed_rate_mm_min == pytest.approx(800.0)


@given(programmed=st.floats(10.0, 5000.0), percent=st.floats(1.0, 200.0))
def test_limits_are_ordered_and_within_the_programmed_feed(programmed, percent):
    sp = constant_load_setpoint(SETUP, programmed)
    assert sp.feed_rate_lower_mm_min <= sp.feed_rate_upper_mm_min <= programmed
    change = tool_change("op", sp, percent)
    if change.due:
        assert change.commanded_feed_rate_mm_min <= sp.feed_rate_lower_mm_min * (1 + 1e-6)


def _plan_with(**changes):
    plan = copy.deepcopy(PLAN)
    plan["operations"][1]["constant_load"].update(changes)
    return plan


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"calibration": "nope"}, "operations[1].constant_load.calibration"),
        ({"max_current_A": -1}, "operations[1].constant_load.max_current_A"),
        ({"safety_factor": 1.5}, "operations[1].constant_load.safety_factor"),
        ({"wear_interval_um": [220, 180]}, "operations[1].constant_load.wear_interval_um"),
        ({"bogus": 1}, "operations[1].constant_load.bogus"),
        # 0.85 × 0.1 A is below the idle current 0.11584 A: no feed draws it
        ({"max_current_A": 0.1}, "operations[1].constant_load.reference_current_A"),
    ],
)
def test_plan_errors_name_the_field(changes, field):
    with pytest.raises(InputError) as info:
        plan_from_mapping(_plan_with(**changes))
    assert info.value.field == field


def test_example_plan_limits():
    result = optimize_plan(plan_from_mapping(PLAN))
    slot = result.operations[0].constant_load
    assert slot is not None
    # slot plane of the example: Eq. 15 at 220 µm plus 2·s/B:
    # (0.238 − 0.11584 − 0.11186·0.22)/2.0693e-4 + 2·0.002/2.0693e-4 = 471.43 + 19.33
    assert slot.feed_rate_lower_mm_min == pytest.approx(490.75, abs=0.01)
    assert slot.feed_rate_upper_mm_min < (0.238 - 0.11584) / 2.0693e-4  # 590.34: the setpoint


def test_rcb_optimize_shows_the_constant_load_limits():
    from typer.testing import CliRunner

    from api.cli.main import app

    plan = str(ROOT / "examples" / "tai_constant_load_part.toml")
    result = CliRunner().invoke(app, ["optimize", plan], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    text = " ".join(result.stdout.split())
    # end-mill: I_ref 0.85 × 0.28 A; lower limit 621.63 mm/min
    # (tests/api/test_rest_constant_load.py);
    # upper: the setpoint's feed, fz 0.0434 mm on the grid (continuous 0.04347, 869.4 mm/min)
    # × 2 flutes × 10 000 rpm = 868 mm/min
    assert "constant load: 0.238 A, feed 621.6-868 mm/min (upper set by the setpoint)" in text
