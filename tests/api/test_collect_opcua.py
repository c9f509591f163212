"""``rcb collect`` over OPC UA (asyncua) against a real ``rcb serve`` and a test server.

Acceptance of issue 20: 20 parts of the demo part collected from an OPC UA subscription give
the same setpoint versions and bands as the same parts posted directly as MES reports.
"""

from __future__ import annotations

from api.virtual_serve.opcua_machine import OpcUaMachine
from supervisor.virtual.trace import block_map

from collect_support import (
    Collector,
    demo_trace,
    mes_reports,
    new_plan,
    outcome,
    post_directly,
    service_parts,
    write_config,
)
from live import free_port

PARTS = 20


def _source(url: str) -> str:
    return "\n".join(
        [
            "[opcua]",
            f'url = "{url}"',
            "publishing_ms = 20",
            "[opcua.nodes]",  # what OPC 40502 does not place; the rest are its defaults
            'part_count = "Machine/PartCount"',
            'tool_number = "Machine/ToolNumber"',
            'program = "Machine/ProgramName"',
        ]
    )


def test_twenty_parts_over_opc_ua_equal_the_same_parts_posted_by_an_mes(sqlite_server, tmp_path):
    plan_id, setpoints = new_plan(sqlite_server)
    direct_id, _ = new_plan(sqlite_server)
    ops, trace = demo_trace(setpoints, PARTS, seed=5)
    machine = OpcUaMachine(trace, free_port())
    machine.start()
    config = write_config(
        tmp_path, sqlite_server.base, plan_id, block_map(ops), _source(machine.url)
    )
    collector = Collector(config, sqlite_server.keys["mes"])
    try:
        collector.start()
        machine.play()
        collector.wait(lambda c: c.get("sent", 0) == PARTS, what="20 parts sent")
        assert collector.counts().get("skips", 0) == 0
    finally:
        collector.stop()
        machine.stop()
    post_directly(sqlite_server, direct_id, mes_reports(ops, trace))
    collected, direct = outcome(sqlite_server, plan_id), outcome(sqlite_server, direct_id)
    assert len(collected["parts"]) == PARTS
    assert len(collected["versions"]) > 1
    assert collected == direct


def test_kill_9_collector_mid_part_over_opc_ua_skips_that_part_and_stores_the_rest_once(
    sqlite_server, tmp_path
):
    """OPC UA keeps no history: the part being made while the collector was down is reported
    as not collected, never posted with a partial force; every other part is stored once."""
    parts = 5
    plan_id, setpoints = new_plan(sqlite_server)
    ops, trace = demo_trace(setpoints, parts, seed=9)
    per_part = (len(trace) - 1) // parts
    machine = OpcUaMachine(trace, free_port())
    machine.start()
    config = write_config(
        tmp_path, sqlite_server.base, plan_id, block_map(ops), _source(machine.url)
    )
    collector = Collector(config, sqlite_server.keys["mes"])
    try:
        collector.start()
        machine.play(until=2 * per_part + per_part // 2)  # parts 1, 2 made, part 3 half made
        collector.wait(lambda c: c.get("sent", 0) == 2, what="parts 1, 2 sent")
        collector.kill()
        collector.start(ready=False)
        collector.wait_log("subscribed to", 2)
        machine.play()
        counts = collector.wait(
            lambda c: c.get("sent", 0) == parts - 1 and c.get("skips", 0) == 1, what="the rest"
        )
    finally:
        collector.stop()
        machine.stop()
    assert counts.get("rejected", 0) == 0
    log = collector.log.read_text()
    assert "parts 3: NOT reported: the collector joined while the part was being made" in log
    assert service_parts(sqlite_server, plan_id) == [f"lathe-1/O1001/{n}" for n in (1, 2, 4, 5)]


def test_a_lost_connection_is_a_gap_and_the_part_it_cuts_is_not_posted(sqlite_server, tmp_path):
    parts = 5
    plan_id, setpoints = new_plan(sqlite_server)
    ops, trace = demo_trace(setpoints, parts, seed=13)
    per_part = (len(trace) - 1) // parts
    port = free_port()
    machine = OpcUaMachine(trace, port)
    machine.start()
    config = write_config(
        tmp_path, sqlite_server.base, plan_id, block_map(ops), _source(machine.url)
    )
    collector = Collector(config, sqlite_server.keys["mes"])
    again = None
    try:
        collector.start()
        cut = 2 * per_part + per_part // 2
        machine.play(until=cut)  # parts 1, 2 made, part 3 half made
        collector.wait(lambda c: c.get("sent", 0) == 2, what="parts 1, 2 sent")
        machine.stop()  # the server goes; the machine runs on
        collector.wait(lambda c: c.get("gaps", 0) == 1, what="the gap")
        again = OpcUaMachine(trace, port, start_at=cut + per_part // 4)
        again.start()
        collector.wait_log("subscribed to", 2)  # reconnected
        again.play()
        counts = collector.wait(
            lambda c: c.get("sent", 0) == parts - 1 and c.get("skips", 0) == 1, what="the rest"
        )
    finally:
        collector.stop()
        if again is not None:
            again.stop()
    assert counts.get("gaps") == 1 and counts.get("rejected", 0) == 0
    log = collector.log.read_text()
    assert "GAP: OPC UA connection lost or refused" in log
    assert "parts 3: NOT reported: OPC UA connection lost" in log, log[-2000:]
    assert service_parts(sqlite_server, plan_id) == [f"lathe-1/O1001/{n}" for n in (1, 2, 4, 5)]
