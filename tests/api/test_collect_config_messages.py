"""collector.toml's refusals, word for word: the field, the value and the reason of each.

An operator reads these on the collector's console (``rcb: error: FIELD = VALUE: REASON``);
they are pinned here so that the readers behind them (:mod:`models.fields`) may change
without the messages changing.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import pytest

from api.collect.config import config_from_mapping
from models.errors import InputError

GOOD = {
    "collector": {"machine": "m"},
    "service": {"url": "http://127.0.0.1:1/api/v1", "plan": 1, "setpoint_version": 1},
    "signal": {"uncertainty": 0.02, "operations": ["a=N1:N2"]},
    "mtconnect": {"url": "http://127.0.0.1:2/dev"},
}
OPCUA = {"url": "opc.tcp://127.0.0.1:4840", "nodes": {"part_count": "ns=2;s=Count"}}
TEXT = "must be text of 1 to 500 characters"
WHOLE = "must be a whole number in 1..2147483647"
MISSING = object()


def _changed(table: str, key: str | None, value: object) -> dict[str, object]:
    data = copy.deepcopy(GOOD)
    if table == "opcua":
        del data["mtconnect"]
        data["opcua"] = dict(OPCUA)
    if key is None:
        if value is MISSING:
            del data[table]
        else:
            data[table] = value
    elif value is MISSING:
        data[table].pop(key, None)  # type: ignore[attr-defined]
    else:
        data[table][key] = value  # type: ignore[index]
    return data


@pytest.mark.parametrize(
    ("table", "key", "value", "field", "shown", "reason"),
    [
        # tables and their fields
        ("colour", None, "red", "colour", "red", "unknown field"),
        ("signal", None, MISSING, "signal", None, "required table missing"),
        ("collector", None, MISSING, "collector", None, "required table missing"),
        ("service", None, [1], "service", [1], "required table missing"),
        ("collector", "colour", "red", "collector.colour", "red", "unknown field"),
        ("service", "token", "x", "service.token", "x", "unknown field"),
        ("signal", "gain", 2, "signal.gain", 2, "unknown field"),
        ("mtconnect", "colour", 1, "mtconnect.colour", 1, "unknown field"),
        ("opcua", "colour", 1, "opcua.colour", 1, "unknown field"),
        # text
        ("collector", "machine", MISSING, "collector.machine", None, TEXT),
        ("collector", "machine", "  ", "collector.machine", "  ", TEXT),
        ("collector", "machine", 7, "collector.machine", 7, TEXT),
        ("collector", "machine", "m" * 501, "collector.machine", "m" * 501, TEXT),
        ("collector", "queue", "", "collector.queue", "", TEXT),
        ("signal", "quantity", None, "signal.quantity", None, TEXT),
        ("signal", "calibration", 3, "signal.calibration", 3, TEXT),
        ("service", "url", MISSING, "service.url", None, TEXT),
        ("service", "api_key_env", "", "service.api_key_env", "", TEXT),
        ("mtconnect", "spindle", 1, "mtconnect.spindle", 1, TEXT),
        ("opcua", "username", "", "opcua.username", "", TEXT),
        ("opcua", "channel", 2, "opcua.channel", 2, TEXT),
        # whole numbers
        ("service", "plan", MISSING, "service.plan", None, WHOLE),
        ("service", "plan", "1", "service.plan", "1", WHOLE),
        ("service", "plan", 0, "service.plan", 0, WHOLE),
        ("service", "plan", True, "service.plan", True, WHOLE),
        ("service", "setpoint_version", 2**31, "service.setpoint_version", 2**31, WHOLE),
        (
            "mtconnect",
            "count",
            100_001,
            "mtconnect.count",
            100_001,
            "must be a whole number in 1..100000",
        ),
        (
            "opcua",
            "queue_size",
            1.0,
            "opcua.queue_size",
            1.0,
            "must be a whole number in 1..1000000",
        ),
        # numbers
        ("signal", "uncertainty", MISSING, "signal.uncertainty", None, "required field missing"),
        ("signal", "uncertainty", "0.1", "signal.uncertainty", "0.1", "must be a number"),
        ("signal", "uncertainty", True, "signal.uncertainty", True, "must be a number"),
        ("signal", "uncertainty", math.inf, "signal.uncertainty", math.inf, "must be a number"),
        ("signal", "uncertainty", 0, "signal.uncertainty", 0, "must be in [1e-09, 1e+12]"),
        ("signal", "percentile", 0, "signal.percentile", 0, "must be in [1e-09, 100]"),
        ("signal", "percentile", 101, "signal.percentile", 101, "must be in [1e-09, 100]"),
        ("collector", "retry_max_s", 0, "collector.retry_max_s", 0, "must be in [0.01, 3600]"),
        ("mtconnect", "poll_s", 61, "mtconnect.poll_s", 61, "must be in [0.001, 60]"),
        ("opcua", "publishing_ms", 0.5, "opcua.publishing_ms", 0.5, "must be in [1, 60000]"),
    ],
)
def test_a_bad_field_is_refused_in_the_same_words(table, key, value, field, shown, reason):
    with pytest.raises(InputError) as err:
        config_from_mapping(_changed(table, key, value), Path("."))
    assert (err.value.field, err.value.reason) == (field, reason)
    assert err.value.value == shown


def test_the_good_file_reads():
    config = config_from_mapping(GOOD, Path("."))
    assert (config.machine, config.plan_id, config.uncertainty) == ("m", 1, 0.02)
    assert (config.percentile, config.retry_max_s, config.api_key_env) == (
        100.0,
        5.0,
        "RCB_API_KEY",
    )
