"""Recursive Constraint Bounding's part reports: a bad one is refused, naming its field, and
changes nothing; a report read from its mapping (JSON) round trip."""

from __future__ import annotations

import json
import math

import pytest
from rcb_support import _report, paper_start

from api.rest.schemas.parts import parse_report
from models.errors import InputError
from supervisor.inputs.part_report import Measurement
from supervisor.rcb.update import update


@pytest.fixture(scope="module")
def state():
    return paper_start()


@pytest.mark.parametrize(
    ("measurements", "field"),
    [
        ({"nope": {"force_N": Measurement(1, 1)}}, "operations.nope"),
        (
            {"rough-od": {"power_kW": Measurement(1, 1)}},
            "operations.rough-od.measurements.power_kW",
        ),
        (
            {"finish-od": {"tool_life_mm3": Measurement(1, 1)}},
            "operations.finish-od.measurements.tool_life_mm3",
        ),
    ],
)
def test_bad_reports_are_refused_and_change_nothing(state, measurements, field):
    before = state
    with pytest.raises(InputError) as err:
        update(state, _report(state, measurements))
    assert err.value.field == field
    assert state == before


def test_unknown_setpoint_version_is_refused(state):
    with pytest.raises(InputError, match="setpoint_version"):
        update(state, _report(state, {}, version=state.version + 5))


@pytest.mark.parametrize("value", [-1.0, math.inf, math.nan])
def test_bad_measurement_values(value):
    with pytest.raises(InputError):
        Measurement(value, 0.1)
    with pytest.raises(InputError):
        Measurement(1.0, value)


GOOD_REPORT = {
    "serial": "P-0001",
    "setpoint_version": 1,
    "operations": [
        {
            "name": "rough-od",
            "measurements": {
                "force_N": {"value": 1565, "uncertainty": 12},  # Table 5 step 1 row R
                "roughness_um": {"value": 3.06, "uncertainty": 0.09},
            },
            "tool_wear": {"flank_wear_mm": {"value": 0.15, "uncertainty": 0.01}, "volume_mm3": 2e6},
        }
    ],
}


def test_a_parsed_report_round_trips(state):
    report = parse_report(GOOD_REPORT)
    assert report.measurements["rough-od"]["force_N"] == Measurement(1565.0, 12.0)
    assert report.tool_wear["rough-od"].volume_mm3 == 2e6
    _, decisions = update(state, report)
    assert [d.quantity for d in decisions] == ["force_N", "roughness_um", "tool_life_mm3"]


def _bad(path, value):
    data = json.loads(json.dumps(GOOD_REPORT))
    *head, last = path
    target = data
    for key in head:
        target = target[key]
    if value is _DROP:
        del target[last]
    else:
        target[last] = value
    return data


_DROP = object()
_M = ["operations", 0, "measurements", "force_N"]


@pytest.mark.parametrize(
    ("path", "value", "field"),
    [
        ([*_M, "value"], -5, "operations[0].measurements.force_N.value"),
        ([*_M, "value"], float("nan"), "operations[0].measurements.force_N.value"),
        ([*_M, "value"], "abc", "operations[0].measurements.force_N.value"),
        ([*_M, "uncertainty"], _DROP, "operations[0].measurements.force_N.uncertainty"),
        ([*_M, "uncertainty"], float("inf"), "operations[0].measurements.force_N.uncertainty"),
        (["setpoint_version"], 0, "setpoint_version"),
        (["serial"], _DROP, "serial"),
        (["operations", 0, "name"], _DROP, "operations[0].name"),
        (["operations", 0, "tool_wear", "volume_mm3"], -1, "operations[0].tool_wear.volume_mm3"),
        (["operations", 0, "measurments"], {}, "operations[0].measurments"),
    ],
)
def test_bad_report_fields_are_named(path, value, field):
    with pytest.raises(InputError) as err:
        parse_report(_bad(path, value))
    assert err.value.field == field


def test_a_report_with_one_bad_quantity_changes_nothing(state):
    # The good measurement before the unknown quantity must not be applied either.
    data = json.loads(json.dumps(GOOD_REPORT))
    data["operations"][0]["measurements"]["forse_N"] = {"value": 1, "uncertainty": 0.5}
    with pytest.raises(InputError) as err:
        update(state, parse_report(data))
    assert err.value.field == "operations.rough-od.measurements.forse_N"
    assert state.tools["rough-od"].models["roughness_um"].dK == 14  # untouched
