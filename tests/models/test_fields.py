"""The one checked-number helper, ``models.fields``: what plans, sensors and the mill share."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from models import fields, misspelt
from models.errors import InputError
from models.sensors import LinearCurrentCalibration
from supervisor.virtual.mill.feed_limits import FeedLimits


@pytest.mark.parametrize("value", [3, 3.5, np.float64(3.5), np.float32(3.5), np.int64(3)])
def test_numbers_include_numpy_scalars_and_come_back_as_floats(value):
    result = fields.number(value, "x")
    assert type(result) is float
    assert result == float(value)


@pytest.mark.parametrize(
    ("value", "said"),
    [
        (True, "x = true"),  # as a file spells it, not Python's True
        (np.bool_(True), "x = true"),
        ("3", "x = '3'"),
        (None, "x"),  # no value: the field alone, not "x = None"
        ([3.0], "x = [3.0]"),
    ],
)
def test_bools_strings_and_lists_are_not_numbers(value, said):
    with pytest.raises(InputError) as refused:
        fields.number(value, "x")
    assert str(refused.value) == f"{said}: must be a number"


def test_messages_name_the_field_and_the_value():
    with pytest.raises(InputError, match=r"^a\.b = inf: must be a finite number$"):
        fields.number(float("inf"), "a.b")
    with pytest.raises(InputError, match=r"^x = 0: must be greater than 0$"):
        fields.positive(0, "x")
    with pytest.raises(InputError, match=r"^x = -1.5: must be at least 0$"):
        fields.at_least(-1.5, "x")
    with pytest.raises(InputError, match=r"^u = -0.1: must be at least 0$"):
        fields.uncertainty(-0.1, "u")
    with pytest.raises(InputError, match=r"^n = 2.0: must be a whole number >= 0$"):
        fields.count(2.0, "n")
    with pytest.raises(InputError, match=r"^v\[1\] = 0: must be greater than 0$"):
        fields.number_list([1, 0], "v", positive=True)
    with pytest.raises(InputError, match=r"^v = 'ab': must be a list of numbers$"):
        fields.number_list("ab", "v")


def test_a_numpy_value_in_a_message_reads_as_a_plain_float():
    with pytest.raises(InputError, match=r"^x = -2.0: must be greater than 0$"):
        fields.number(np.float32(-2.0), "x", positive=True)


@dataclass(frozen=True)
class _Part:
    a: float
    b: float = 0.0
    r: float = 0.0
    c: float | None = None


def test_check_field_stores_plain_floats_and_keeps_an_optional_none():
    part = _Part(np.int64(2), np.float32(0.5))
    fields.check_fields(part, positives=("a",), non_negatives=("b",))
    fields.check_field(part, "c", positive=True, optional=True)
    assert (type(part.a), type(part.b), part.c) == (float, float, None)
    with pytest.raises(InputError, match=r"^c: must be a number$"):
        fields.check_field(part, "c", positive=True)
    with pytest.raises(InputError, match=r"^r = 1.5: must be a correlation coefficient"):
        fields.check_field(_Part(1.0, r=1.5), "r", correlation=True)


def test_sensors_and_the_mill_check_through_fields():
    with pytest.raises(InputError, match=r"^slope_N_per_A = 0.0: must be greater than 0$"):
        LinearCurrentCalibration(offset_N=0.0, slope_N_per_A=0.0)
    with pytest.raises(InputError, match=r"^lower_feed_rate_mm_min = -1: must be greater than 0$"):
        FeedLimits(-1, 10.0)
    assert type(FeedLimits(np.int64(1), 10).lower_feed_rate_mm_min) is float


def test_a_message_shows_a_value_as_a_plan_file_or_a_request_spells_it():
    """Python's spelling reached the user: ``operations = None: a plan needs ...``, ``= True``,
    ``--model ... = {'K': 2500.0}`` (a first-day audit)."""
    said = {
        None: "operations: x",  # no value: the field alone
        True: "operations = true: x",
        np.bool_(False): "operations = false: x",
        np.float64(2.5): "operations = 2.5: x",
        2.0: "operations = 2.0: x",  # kept: "must be a whole number" of "2" would not read
        "abc": "operations = 'abc': x",
    }
    for value, message in said.items():
        assert str(InputError("operations", value, "x")) == message
    table = {"K": 2500.0, "e": [1, None, True], "n": np.float32(0.5)}
    assert (
        str(InputError("m", table, "x")) == 'm = {"K": 2500.0, "e": [1, null, true], "n": 0.5}: x'
    )
    assert str(InputError("m", np.array([1.0, 2.0]), "x")) == "m = array([1., 2.]): x"


@pytest.mark.parametrize(
    ("name", "known", "expected"),
    [
        ("Force_N", ["force_N", "roughness_um"], "force_N"),  # case
        (" force_N ", ["force_N", "roughness_um"], "force_N"),  # white space
        ("forse_N", ["force_N", "roughness_um"], "force_N"),  # a letter
        ("alfa", ["alpha", "z", "strategy"], "alpha"),  # difflib's 0.667, over its 0.6
        ("power_kW", ["force_N", "roughness_um"], None),  # another quantity, not a typo
        ("bogus", ["serial", "setpoint_version", "operations"], None),
        ("x", [], None),
    ],
)
def test_meant_is_the_one_name_a_misspelling_is_close_to(name, known, expected):
    assert misspelt.meant(name, known) == expected


def test_an_unknown_field_of_a_file_names_the_one_it_may_mean():
    with pytest.raises(InputError) as caught:
        fields.only_keys({"feed_mm_rv": 0.2}, ["feed_mm_rev", "speed_m_min"], "operations.od")
    assert str(caught.value) == (
        "operations.od.feed_mm_rv = 0.2: unknown field (did you mean 'feed_mm_rev'?); "
        "expected one of: feed_mm_rev, speed_m_min"
    )
    with pytest.raises(InputError) as caught:  # nothing close: the list alone, as before
        fields.only_keys({"colour": "red"}, ["feed_mm_rev", "speed_m_min"], "")
    assert str(caught.value) == (
        "colour = 'red': unknown field; expected one of: feed_mm_rev, speed_m_min"
    )
