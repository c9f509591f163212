"""Issue 17, item 4: a part report the physics cannot produce is refused, naming the field.

``api.rest.schemas.parts.parse_report`` reads JSON-like data with the REST body's schema, the one
place a report is checked (issue 31, item 3).
"""

from __future__ import annotations

import copy

import pytest

from api.rest.schemas.parts import parse_report
from models.errors import InputError
from supervisor.inputs.part_report import Measurement

REPORT = {
    "serial": "P-0001",
    "setpoint_version": 1,
    "operations": [
        {
            "name": "rough-od",
            "measurements": {"force_N": {"value": 1565, "uncertainty": 12}},
            "tool_wear": {"flank_wear_mm": {"value": 0.15, "uncertainty": 0.01}, "volume_mm3": 2e6},
        }
    ],
}
F = ("operations", 0, "measurements", "force_N")
FIELD = "operations[0].measurements.force_N"
W = ("operations", 0, "tool_wear", "flank_wear_mm")


def _with(path, value):
    data = copy.deepcopy(REPORT)
    *head, last = path
    target = data
    for key in head:
        target = target[key]
    target[last] = value
    return data


@pytest.mark.parametrize(
    ("path", "value", "field"),
    [
        ((*F, "value"), True, f"{FIELD}.value"),
        ((*F, "value"), "5", f"{FIELD}.value"),
        ((*F, "value"), 0, f"{FIELD}.value"),
        ((*F, "value"), 1e13, f"{FIELD}.value"),
        ((*F, "value"), 1e308, f"{FIELD}.value"),
        ((*F, "uncertainty"), 0, f"{FIELD}.uncertainty"),
        ((*F, "uncertainty"), 1565, f"{FIELD}.uncertainty"),
        ((*W, "uncertainty"), 0.2, "operations[0].tool_wear.flank_wear_mm.uncertainty"),
        (("operations", 0, "tool_wear", "volume_mm3"), 1e300, "operations[0].tool_wear.volume_mm3"),
        (("operations",), [], "operations"),
        (("operations", 0), {"name": "rough-od", "measurements": {}}, "operations[0].measurements"),
        (("serial",), "P\x01", "serial"),
        (("serial",), "P\u202e1", "serial"),
        (("serial",), "P\ud800", "serial"),
        (("operations", 0, "name"), "rough\tod", "operations[0].name"),
        # a quantity the registry does not know is still read as a reading (the plan's tool
        # refuses it later, naming what it measures)
        (
            ("operations", 0, "measurements", "torque_Nm"),
            {"value": "5", "uncertainty": 1},
            "operations[0].measurements.torque_Nm.value",
        ),
        # a calibration is for a raw spindle reading only
        ((*F, "calibration"), "spindle", "operations[0].measurements"),
    ],
)
def test_a_report_the_physics_cannot_produce_is_refused_naming_the_field(path, value, field):
    with pytest.raises(InputError) as err:
        parse_report(_with(path, value))
    assert err.value.field == field


def test_an_operation_reported_twice_is_refused():
    again = {"name": " rough-od", "feed_override_percent": 80.0}  # the same name, normalised
    operations = [*REPORT["operations"], again]
    first = next(i for i, op in enumerate(operations) if op["name"] == "rough-od")
    with pytest.raises(InputError) as err:
        parse_report({**REPORT, "operations": operations})
    # the second by its index, as an unknown operation is named (not the whole list)
    assert err.value.field == f"operations[{len(operations) - 1}].name"
    assert (err.value.value, err.value.reason) == (
        "rough-od",
        f"reported twice: also operations[{first}]",
    )


def test_a_raw_spindle_current_is_a_signal_and_a_bare_one_a_measurement():
    raw = {"value": 12.0, "uncertainty": 0.2, "spindle_speed_rpm": 900.0}
    bare = {"value": 12.0, "uncertainty": 0.2}
    op = {"name": "slot", "measurements": {"spindle_current_A": raw}}
    other = {"name": "face", "measurements": {"spindle_current_A": bare}}
    report = parse_report({**REPORT, "operations": [op, other]})
    signal = report.signals["slot"]["spindle_current_A"]
    assert signal.context == {"spindle_speed_rpm": 900.0} and signal.calibration is None
    assert report.measurements == {
        "slot": {},
        "face": {"spindle_current_A": Measurement(12.0, 0.2)},
    }


def test_a_feed_override_alone_is_something_measured():
    op = {"name": "slot", "feed_override_percent": 80.0}
    report = parse_report({**REPORT, "operations": [op]})
    assert report.feed_overrides == {"slot": 80.0}


def test_the_example_report_is_read():
    report = parse_report(REPORT)
    assert report.measurements["rough-od"]["force_N"].value == 1565.0
    assert report.tool_wear["rough-od"].flank_wear_mm.uncertainty == 0.01
