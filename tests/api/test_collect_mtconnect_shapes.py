"""MTConnect devices in the shapes of the reference agent's samples: the right item of each signal.

Acceptance of issue 28: documents written here (``tests/data/mtconnect/``) in the shapes of
cppagent's samples (Fanuc, Haas, the test sample in 2.x names, the 1.0 agent sample), each a
case, give the spindle load of the spindle (not of another axis, not a LOAD condition), the feed
rate in mm/min from the units the device declares, and neither an override nor a count of parts
remaining; a device whose only feed rate is an override is an input error, not a rate.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from api.collect.config import MTCONNECT_ITEMS
from api.collect.mtconnect import latest_values, parse_streams
from api.collect.mtconnect_devices import bind, parse_devices, with_modes
from api.virtual_serve.mtconnect_agent import Agent, observations, serve
from models.errors import InputError
from supervisor.virtual.trace import TraceSample

from collect_support import refused

DATA = Path(__file__).parents[1] / "data" / "mtconnect"
REQUIRED = ("spindle_load", "part_count", "execution", "block")


def _read(shape: str, items=MTCONNECT_ITEMS, spindle=None) -> dict[str, object]:
    device = parse_devices((DATA / f"{shape}_devices.xml").read_bytes())
    binding = bind(device, items, spindle=spindle, required=REQUIRED)
    streams = parse_streams((DATA / f"{shape}_streams.xml").read_bytes(), binding)
    return {o.item: o.value for o in streams.observations}


@pytest.mark.parametrize(
    ("shape", "expected"),
    [
        (  # spindle C (Rotary, SPINDLE mode) 37.5 %, not A's 81 % nor X's 12 %; 25.5 mm/s; not
            # the 120 % override (a PATH_FEEDRATE in PERCENT without subType)
            "fanuc",
            {
                "spindle_load": 37.5,
                "spindle_speed_rpm": 1061.0,
                "feed_rate_mm_min": 25.5 * 60,
                "block": 120,
                "part_count": 17,
                "execution": "ACTIVE",
                "program": "O1001",
            },
        ),
        (  # 60 inch/min in nativeUnits only (streamed unconverted) = 1524 mm/min; Block under
            # Controller; Z's 64 % is not the spindle's 22 %
            "haas",
            {
                "spindle_load": 22.0,
                "spindle_speed_rpm": 2400.0,
                "feed_rate_mm_min": 60.0 * 25.4,
                "block": 310,
                "part_count": 4,
                "execution": "ACTIVE",
                "program": "O2002",
            },
        ),
        (  # 2.x names (ROTARY_VELOCITY); the ACTUAL feed rate, not the PROGRAMMED; the parts
            # made (41), not the parts remaining (3); the LOAD sample, not the LOAD condition
            "test_sample",
            {
                "spindle_load": 18.25,
                "spindle_speed_rpm": 1200.5,
                "feed_rate_mm_min": 9.75 * 60,
                "block": 140,
                "part_count": 41,
                "execution": "ACTIVE",
                "program": "O3003",
            },
        ),
        (  # 1.0: a Spindle component, the feed rate under Axes, Block under Controller, no Path
            "v1_0",
            {
                "spindle_load": 310.0,
                "spindle_speed_rpm": 800.0,
                "feed_rate_mm_min": 4.2 * 60,
                "block": 200,
                "part_count": 9,
                "execution": "ACTIVE",
                "program": "O4004",
            },
        ),
    ],
)
def test_each_sample_shape_gives_the_spindle_load_and_the_feed_rate_in_mm_min(shape, expected):
    got = _read(shape)
    assert set(got) == set(expected)
    for signal, value in expected.items():
        if isinstance(value, float):
            assert got[signal] == pytest.approx(value, rel=1e-12), signal
        else:
            assert got[signal] == value, signal


@pytest.mark.parametrize(
    ("shape", "only_override", "named"),
    [
        ("fanuc", ('id="m1_pf"', 'id="m1_pf_gone"'), "m1_fovr (path/PATH_FEEDRATE, PERCENT)"),
        ("haas", ('id="h_f"', 'id="h_f_gone"'), "h_fovr (path/PATH_FEEDRATE OVERRIDE, PERCENT)"),
    ],
)
def test_a_device_whose_only_feed_rate_is_an_override_is_an_input_error(
    shape, only_override, named
):
    text = (DATA / f"{shape}_devices.xml").read_text(encoding="utf-8")
    start = text.index(only_override[0])
    line_start, line_end = text.rindex("<DataItem", 0, start), text.index("/>", start) + 2
    device = parse_devices((text[:line_start] + text[line_end:]).encode())
    with pytest.raises(InputError) as err:
        bind(device, MTCONNECT_ITEMS, required=REQUIRED)
    assert err.value.field == "mtconnect.data_items.feed_rate_mm_min"
    assert f"only an override on the agent ({named}), no rate" in str(err.value)


def test_the_spindle_named_in_the_file_wins_and_a_wrong_name_lists_the_components():
    # the A axis named as the spindle: its load is read (the file is the operator's word)
    assert _read("fanuc", spindle="A")["spindle_load"] == 81.0
    with pytest.raises(InputError) as err:
        _read("fanuc", spindle="B")
    assert err.value.field == "mtconnect.spindle"
    assert str(err.value) == "mtconnect.spindle = 'B': no such component: A, C"


def test_a_rotary_whose_mode_may_change_is_the_spindle_while_its_mode_is_spindle():
    text = (DATA / "fanuc_devices.xml").read_text(encoding="utf-8")
    free = text.replace("<Constraints><Value>SPINDLE</Value></Constraints>", "")
    device = parse_devices(free.encode())
    with pytest.raises(InputError) as err:  # no spindle known before its mode is read
        bind(device, MTCONNECT_ITEMS, required=REQUIRED)
    assert "no spindle on the agent" in str(err.value) and "components: A, C" in str(err.value)
    current = (DATA / "fanuc_streams.xml").read_bytes()
    modes = latest_values(current, tuple(device.rotary_modes))
    assert modes == {"m1_cm": "SPINDLE"}
    binding = bind(with_modes(device, modes), MTCONNECT_ITEMS, required=REQUIRED)
    assert binding["spindle_load"].item.id == "m1_cl"


def test_two_spindles_are_ambiguous_until_one_is_named():
    text = (DATA / "fanuc_devices.xml").read_text(encoding="utf-8")
    two = text.replace("<Value>INDEX</Value>", "<Value>SPINDLE</Value>")
    device = parse_devices(two.encode())
    with pytest.raises(InputError) as err:
        bind(device, MTCONNECT_ITEMS, required=REQUIRED)
    assert err.value.field == "mtconnect.data_items.spindle_load"
    assert "ambiguous: m1_cl (C/LOAD ACTUAL, PERCENT), m1_al (A/LOAD, PERCENT)" in str(err.value)
    assert bind(device, MTCONNECT_ITEMS, spindle="C")["spindle_load"].item.id == "m1_cl"


def test_a_unit_the_signal_cannot_be_converted_from_and_a_missing_signal_are_named():
    text = (DATA / "fanuc_devices.xml").read_text(encoding="utf-8")
    degrees = text.replace('units="MILLIMETER/SECOND"', 'units="DEGREE/SECOND"')
    device = parse_devices(degrees.encode())
    with pytest.raises(InputError) as err:
        bind(device, MTCONNECT_ITEMS)
    assert err.value.field == "mtconnect.data_items.feed_rate_mm_min"
    assert "units DEGREE/SECOND not one of MILLIMETER/SECOND" in str(err.value)
    no_count = parse_devices(text.replace('type="PART_COUNT"', 'type="PART_ID"').encode())
    with pytest.raises(InputError) as err:
        bind(no_count, MTCONNECT_ITEMS, required=REQUIRED)
    assert str(err.value) == (
        "mtconnect.data_items.part_count = 'Path/PartCount': not on the agent's device "
        "'Fanuc-4Axis'"
    )


def test_rcb_collect_refuses_an_agent_whose_only_feed_rate_is_an_override_in_one_line(tmp_path):
    trace = [
        TraceSample(0, "READY", 9000, 1, 0.0, 0.0, 0.0),
        TraceSample(0, "ACTIVE", 100, 1, 1.25, 1000.0, 300.0),
    ]
    agent = Agent(observations(trace), buffer_size=100)
    agent.release(100)
    actual = agent.probe()
    start = actual.index('<DataItem category="SAMPLE" id="Frt"')
    without = actual[:start] + actual[actual.index("/>", start) + 2 :]
    agent.probe = lambda: without  # type: ignore[method-assign]
    server, url = serve(agent)
    try:
        errors, stderr = refused(tmp_path, f'[mtconnect]\nurl = "{url}"\npoll_s = 0.02')
    finally:
        server.shutdown()
    assert errors == [
        "rcb: error: mtconnect.data_items.feed_rate_mm_min = 'Path/PathFeedrate': only an "
        "override on the agent (Fovr (path/PATH_FEEDRATE OVERRIDE, PERCENT)), no rate"
    ], stderr[-2000:]
