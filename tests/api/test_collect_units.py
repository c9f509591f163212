"""The collector's pure parts and its file formats, in process (fast): segmentation, selectors,
report keys, the queue, the MTConnect reader, collector.toml errors and ``rcb collect`` errors."""

from __future__ import annotations

import json
import string

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from api.cli.main import app
from api.collect.config import config_from_mapping
from api.collect.mtconnect import AgentError, parse_streams
from api.collect.queue import Checkpoint, open_queue
from api.virtual_serve.mtconnect_agent import Agent, observations
from models.errors import InputError
from supervisor.collect.report import idempotency_key, part_report, serial_of
from supervisor.collect.segment import Gap, Observation, PartDone, PartSkipped, Segmenter
from supervisor.collect.selectors import block_number, check_selectors, parse_selector

OPS = [parse_selector("rough=N100:N140"), parse_selector("finish=N200:N240")]


def _feed(segmenter, events, start=1):
    """Feed ``(item, value)`` pairs (or Gap objects) with sequence numbers; the outcomes."""
    out = []
    for i, event in enumerate(events, start=start):
        if isinstance(event, Gap):
            segmenter.gap(event)
        else:
            out += segmenter.feed(Observation(i, *event))
    return out


def _part(count, rough, finish):
    """One part's events: READY→ACTIVE, the loads of each operation, then the count."""
    events = [("execution", "ACTIVE"), ("spindle_speed_rpm", 1000.0)]
    for block, loads in ((100, rough), (200, finish)):
        events.append(("block", block))
        events += [("spindle_load", v) for v in loads]
    events += [("block", 9000), ("spindle_load", 99.0), ("execution", "READY")]
    events += [("spindle_load", 99.0), ("part_count", count)]
    return events


loads = st.lists(st.floats(0.1, 10.0), min_size=1, max_size=20)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(loads, loads), min_size=1, max_size=5), st.integers(0, 6))
def test_each_part_is_the_max_of_its_own_samples_and_a_gap_skips_the_part_it_hits(parts, hit):
    events = [("execution", "READY"), ("part_count", 0)]
    for count, (rough, finish) in enumerate(parts, start=1):
        part = _part(count, rough, finish)
        if count == hit:
            part.insert(3, Gap(5, 9, "the agent's buffer wrapped"))
        events += part
    outcomes = _feed(Segmenter(OPS), events)
    assert len(outcomes) == len(parts)
    for count, (outcome, (rough, finish)) in enumerate(zip(outcomes, parts, strict=True), start=1):
        if count == hit:  # never posted with a wrong force
            assert isinstance(outcome, PartSkipped) and outcome.part_counts == (count,)
            assert "sequences 5..9 lost" in outcome.reason
            continue
        assert isinstance(outcome, PartDone) and outcome.part_count == count
        # samples outside a mapped block (99.0 at N9000) or not ACTIVE never count
        assert [p.value for p in outcome.passes] == [max(rough), max(finish)]
        assert [p.samples for p in outcome.passes] == [len(rough), len(finish)]
        assert outcome.passes[0].spindle_speed_rpm == 1000.0


@settings(max_examples=30, deadline=None)
@given(loads, st.floats(1.0, 100.0))
def test_a_percentile_reading_lies_between_the_samples_and_100_is_the_max(values, q):
    events = [("execution", "READY"), ("part_count", 0), *_part(1, values, [1.0])]
    (done,) = _feed(Segmenter(OPS, percentile=q), events)
    assert min(values) - 1e-12 <= done.passes[0].value <= max(values) + 1e-12
    assert done.passes[0].value == pytest.approx(float(np.percentile(values, q)))


def test_a_collector_that_joins_a_running_part_skips_it_and_not_a_machine_at_rest():
    running = [("part_count", 4), ("execution", "ACTIVE"), ("block", 100), ("spindle_load", 1.0)]
    (skipped,) = _feed(Segmenter(OPS), running + _part(5, [2.0], [3.0])[2:])
    assert isinstance(skipped, PartSkipped) and skipped.part_counts == (5,)
    assert "joined" in skipped.reason
    (done,) = _feed(
        Segmenter(OPS), [("part_count", 4), ("execution", "READY"), *_part(5, [2.0], [3.0])]
    )
    assert isinstance(done, PartDone)


def test_a_count_jump_or_reset_names_every_part_it_skips():
    events = [("execution", "READY"), ("part_count", 1), *_part(4, [2.0], [3.0])]
    (jump,) = _feed(Segmenter(OPS), events)
    assert jump.part_counts == (2, 3, 4) and "jumped from 1 to 4" in jump.reason
    (reset,) = _feed(Segmenter(OPS), [("execution", "READY"), ("part_count", 9), ("part_count", 0)])
    assert reset.part_counts == (0,) and "went back from 9 to 0" in reset.reason


def test_state_snapshot_resumes_the_same_segmentation():
    first = Segmenter(OPS, joined_mid_part=False)
    _feed(first, [("execution", "READY"), ("part_count", 0), *_part(1, [1.0], [1.0])])
    again = Segmenter(OPS, state=json.loads(json.dumps(first.snapshot())))
    a = _feed(first, _part(2, [5.0, 6.0], [7.0]))
    b = _feed(again, _part(2, [5.0, 6.0], [7.0]))
    assert a == b and isinstance(a[0], PartDone)


def test_selectors_reuse_the_gcode_map_form_and_refuse_what_cannot_be_told_apart():
    assert parse_selector("rough-od=N100:N200").describe() == "rough-od=N100:N200"
    assert parse_selector("rough-od=100:200").first_block == 100  # as rcb gcode --map
    assert parse_selector("finish=T3").tool_number == 3
    with pytest.raises(InputError) as err:
        parse_selector("rough-od=N100-N200", "signal.operations")
    assert err.value.field == "signal.operations"
    for bad in (["a=N100:N200", "b=N150:N300"], ["a=T1", "b=T1"], ["a=T1", "b=N1:N2"]):
        with pytest.raises(InputError):
            check_selectors([parse_selector(s) for s in bad])
    assert block_number("/N120 G01 Z-110.") == 120
    assert block_number("G01 Z-110.") is None and block_number(None) is None


@settings(max_examples=50, deadline=None)
@given(st.text(min_size=1, max_size=300), st.text(min_size=1, max_size=300), st.integers(0, 10**9))
def test_key_and_serial_are_deterministic_and_what_the_service_takes(machine, program, count):
    key = idempotency_key(7, machine, program, count)
    assert key == idempotency_key(7, machine, program, count)
    assert 1 <= len(key) <= 255 and all(33 <= ord(c) <= 126 for c in key)
    assert key != idempotency_key(7, machine, program, count + 1)
    assert key != idempotency_key(8, machine, program, count)  # keys are per API key, not plan
    assert 1 <= len(serial_of(machine, program, count)) <= 200


def test_report_carries_the_reading_and_leaves_out_one_below_its_uncertainty():
    done = PartDone(3, "O1", (), ("rough",), 10)
    body, left_out = part_report(
        done,
        machine="m",
        setpoint_version=2,
        quantity="spindle_load_V",
        uncertainty=0.02,
        calibration="spindle_load",
    )
    assert body["operations"] == [] and left_out == ["rough: no load sample while ACTIVE"]


def test_queue_keeps_a_key_once_and_moves_the_checkpoint_with_the_part(tmp_path):
    queue = open_queue(tmp_path / "q.sqlite")
    point = Checkpoint("mtconnect", "1", 42, {"part_count": 3})
    assert queue.record(point, report=("k1", 3, "O1", b"{}")) is True
    assert (
        queue.record(Checkpoint("mtconnect", "1", 99, {}), report=("k1", 3, "O1", b"{}")) is False
    )
    assert queue.checkpoint() == Checkpoint("mtconnect", "1", 99, {})
    pending = queue.next_pending()
    assert pending is not None and pending.idempotency_key == "k1"
    queue.settle(pending.id, "sent", 201, {"part_id": 1})
    assert queue.next_pending() is None and queue.status()["sent"] == 1
    queue.close()


def test_mtconnect_reader_takes_sequences_and_the_agent_error(tmp_path):
    from supervisor.virtual.trace import TraceSample

    trace = [
        TraceSample(0, "READY", 9000, 1, 0.0, 0.0, 0.0),
        TraceSample(0, "ACTIVE", 100, 1, 1.25, 1000.0, 300.0),
    ]
    agent = Agent(observations(trace), buffer_size=5)
    agent.release(100)
    from api.collect.config import MTCONNECT_ITEMS
    from api.collect.mtconnect_devices import bind, parse_devices

    binding = bind(parse_devices(agent.probe().encode()), MTCONNECT_ITEMS)
    streams = parse_streams(agent.current().encode(), binding)
    got = {o.item: o.value for o in streams.observations}
    assert got["block"] == 100 and got["spindle_load"] == 1.25 and got["execution"] == "ACTIVE"
    assert got["feed_rate_mm_min"] == 300.0  # streamed as 5 mm/s (the device's units)
    assert streams.next_sequence == len(agent.obs) + 1 and streams.first_sequence > 1
    with pytest.raises(AgentError) as err:
        parse_streams(agent.sample(1, 10)[1].encode(), binding)
    assert err.value.code == "OUT_OF_RANGE"


def _config(**changes):
    data = {
        "collector": {"machine": "m"},
        "service": {"url": "http://127.0.0.1:1/api/v1", "plan": 1, "setpoint_version": 1},
        "signal": {"uncertainty": 0.02, "operations": ["a=N1:N2"]},
        "mtconnect": {"url": "http://127.0.0.1:2/dev"},
    }
    for path, value in changes.items():
        table, key = path.split("__")
        if value is None:
            data[table].pop(key, None)
        else:
            data[table][key] = value
    return data


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"signal__uncertainty": None}, "signal.uncertainty"),
        ({"signal__quantity": "force_N"}, "signal.quantity"),
        ({"signal__operations": ["a=N5:N1"]}, "signal.operations"),
        ({"signal__percentile": 0}, "signal.percentile"),
        ({"service__plan": "1"}, "service.plan"),
        ({"mtconnect__url": "ftp://x"}, "mtconnect.url"),
        ({"collector__colour": "red"}, "collector.colour"),
    ],
)
def test_config_errors_name_the_field(tmp_path, change, field):
    with pytest.raises(InputError) as err:
        config_from_mapping(_config(**change), tmp_path)
    assert err.value.field == field


def test_rcb_collect_refuses_a_bad_file_in_one_line_and_never_prints_the_key(tmp_path, monkeypatch):
    runner = CliRunner()
    path = tmp_path / "collector.toml"
    path.write_text('[collector]\nmachine = "m"\n[service]\nurl = "x"\n', encoding="utf-8")
    result = runner.invoke(app, ["collect", "--config", str(path)])
    assert result.exit_code == 2
    assert "rcb: error: signal: required table missing" in result.output
    config = tmp_path / "ok.toml"
    lines = [
        '[collector]\nmachine = "m"\n[service]\nurl = "http://127.0.0.1:1/api/v1"\nplan = 1',
        'setpoint_version = 1\napi_key_env = "RCB_TEST_UNSET_KEY"',
        '[signal]\nuncertainty = 0.02\noperations = ["a=N1:N2"]',
        '[mtconnect]\nurl = "http://127.0.0.1:2/d"',
    ]
    config.write_text("\n".join(lines) + "\n", encoding="utf-8")
    monkeypatch.delenv("RCB_TEST_UNSET_KEY", raising=False)
    result = runner.invoke(app, ["collect", "--config", str(config)])
    assert result.exit_code == 2 and "RCB_TEST_UNSET_KEY" in result.output
    monkeypatch.setenv("RCB_TEST_UNSET_KEY", "s3cret-key")
    status = runner.invoke(app, ["collect", "--config", str(config), "--status"])
    assert status.exit_code == 0 and "s3cret" not in status.output
    assert "pending 0  sent 0  rejected 0" in status.output
    assert all(len(line) <= 80 for line in status.output.splitlines())
    assert set(string.printable) >= set(status.output)


def test_operations_by_tool_number_cut_passes_at_tool_changes():
    by_tool = [parse_selector("rough=T1"), parse_selector("finish=T3")]
    events = [("execution", "READY"), ("part_count", 0), ("execution", "ACTIVE")]
    events += [("tool_number", 1), ("spindle_load", 2.0), ("spindle_load", 2.5)]
    events += [("tool_number", 2), ("spindle_load", 9.0)]  # a tool no operation uses
    events += [("tool_number", 3), ("spindle_load", 1.5), ("execution", "READY")]
    events += [("spindle_load", 8.0), ("part_count", 1)]
    (done,) = _feed(Segmenter(by_tool), events)
    assert [(p.operation, p.value, p.samples) for p in done.passes] == [
        ("rough", 2.5, 2),
        ("finish", 1.5, 1),
    ]


def test_the_docs_example_is_a_valid_collector_file(tmp_path):
    import tomllib
    from pathlib import Path

    # README's "rcb collect" section is the docs site's page since issue 30
    text = (Path(__file__).parents[2] / "docs/guide/collect.md").read_text(encoding="utf-8")
    section = text[text.index("# rcb collect: machine data in") :]
    example = section[section.index("```toml\n") + 8 : section.index("```\n", 10)]
    config = config_from_mapping(tomllib.loads(example), tmp_path)
    assert config.machine == "lathe-1" and config.mtconnect is not None
    assert [s.describe() for s in config.selectors] == ["rough-od=N100:N180", "finish-od=N300:N350"]
    assert config.mtconnect.items["spindle_load"] == "Rotary/Load"
