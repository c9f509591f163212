"""``rcb collect`` over OPC UA against servers it did not write: the OPC Foundation's nodesets.

Acceptance of issue 28: an asyncua server whose address space is imported from the official
OPC 40502 CNC and OPC 40501 Machine Tool nodesets (``tests/opcua_nodesets.py``), and a second,
independent server implementation (node-opcua, ``tests/opcua_node_server.js``) loading the same
nodesets, each feed ``rcb collect`` 20 parts that equal the same parts posted directly; a path
that is not on the server is one line naming it and what the server has there. The nodesets and
node-opcua come from npm at test time (``tests/npm_packages.py``); without node, npm or the
registry these tests skip, saying so.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from api.virtual_serve.opcua_machine import OpcUaMachine, own_space
from supervisor.virtual.trace import TraceSample, block_map

from collect_support import (
    Collector,
    demo_trace,
    mes_reports,
    new_plan,
    outcome,
    post_directly,
    refused,
    write_config,
)
from live import free_port
from npm_packages import nodeset_folder, npm_folder
from opcua_node_machine import NodeOpcUaMachine
from opcua_nodesets import COLLECTOR_NODES, OfficialSpace

PARTS = 20


def _source(url: str, **nodes: str) -> str:
    lines = ["[opcua]", f'url = "{url}"', "publishing_ms = 20", "[opcua.nodes]"]
    lines += [f'{item} = "{path}"' for item, path in {**COLLECTOR_NODES, **nodes}.items()]
    return "\n".join(lines)


def _twenty_parts(live, tmp_path, server_for) -> None:
    """20 parts through ``rcb collect`` from the server ``server_for(trace)`` equal an MES's."""
    plan_id, setpoints = new_plan(live)
    direct_id, _ = new_plan(live)
    ops, trace = demo_trace(setpoints, PARTS, seed=5)
    machine = server_for(trace)
    machine.start()
    config = write_config(tmp_path, live.base, plan_id, block_map(ops), _source(machine.url))
    collector = Collector(config, live.keys["mes"])
    try:
        collector.start()
        machine.play()
        collector.wait(lambda c: c.get("sent", 0) == PARTS, timeout_s=120, what="20 parts sent")
        assert collector.counts().get("skips", 0) == 0
    finally:
        collector.stop()
        machine.stop()
    post_directly(live, direct_id, mes_reports(ops, trace))
    collected, direct = outcome(live, plan_id), outcome(live, direct_id)
    assert len(collected["parts"]) == PARTS
    assert len(collected["versions"]) > 1  # RCB moved the bands: the comparison has teeth
    assert collected == direct


def test_twenty_parts_from_asyncua_with_the_official_cnc_and_machine_tool_nodesets(
    sqlite_server, tmp_path
):
    space = OfficialSpace(nodeset_folder())
    _twenty_parts(sqlite_server, tmp_path, lambda t: OpcUaMachine(t, free_port(), space=space))


def test_twenty_parts_from_a_node_opcua_server(sqlite_server, tmp_path):
    npm = npm_folder()
    _twenty_parts(
        sqlite_server, tmp_path, lambda t: NodeOpcUaMachine(t, free_port(), npm, tmp_path)
    )


@pytest.fixture(scope="module")
def official_machine() -> Iterator[OpcUaMachine]:
    """One asyncua server with the official nodesets, never played, that the collectors of the
    paths below are refused by (importing the nodesets takes 5-15 s: once, not per path)."""
    space = OfficialSpace(nodeset_folder())
    trace = [
        TraceSample(0, "READY", 9000, 1, 0.0, 0.0, 0.0),
        TraceSample(0, "ACTIVE", 100, 1, 1.25, 1000.0, 300.0),
    ]
    machine = OpcUaMachine(trace, free_port(), space=space)
    machine.start()
    yield machine
    machine.stop()


@pytest.mark.parametrize(
    ("nodes", "expected"),
    [
        (  # a spindle the server does not have: named, with the one it has (9: the test's own)
            {"spindle_load": "CNC:CncInterface/CNC:CncSpindleList/Spindel/CNC:ActLoad"},
            "rcb: error: opcua.nodes.spindle_load = "
            "'CNC:CncInterface/CNC:CncSpindleList/Spindel/CNC:ActLoad': no node 'Spindel' under "
            "Objects/CNC:CncInterface/CNC:CncSpindleList; it has 9:Spindle",
        ),
        (  # the CNC namespace index of another server: 3 is DI here (CNC is 2)
            {"feed_rate_mm_min": "3:CncInterface/CNC:CncChannelList/Channel/CNC:ActFeedrate"},
            "rcb: error: opcua.nodes.feed_rate_mm_min = "
            "'3:CncInterface/CNC:CncChannelList/Channel/CNC:ActFeedrate': no node "
            "'3:CncInterface' under Objects; it has 0:Aliases, ",
        ),
        (
            {"part_count": "ns=7;s=PartCount"},
            "rcb: error: opcua.nodes.part_count = 'ns=7;s=PartCount': "
            "the server has no node with this NodeId",
        ),
    ],
)
def test_a_path_not_on_the_server_is_one_line_naming_it(
    official_machine, tmp_path, nodes, expected
):
    errors, stderr = refused(tmp_path, _source(official_machine.url, **nodes))
    assert len(errors) == 1 and errors[0].startswith(expected), stderr[-2000:]


async def _slash_space(server, first):
    """OPC 40502's BrowseNames under the CNC URI with a trailing slash (as this project had it)."""
    space = await own_space(server, first)
    uri = "http://opcfoundation.org/UA/CNC"
    array = await server.get_namespace_array()
    await server.nodes.namespace_array.write_value([f"{uri}/" if u == uri else u for u in array])
    return space


def test_a_server_without_the_cnc_namespace_is_one_line_listing_its_namespaces(tmp_path):
    trace = [TraceSample(0, "READY", 9000, 1, 0.0, 0.0, 0.0)] * 2
    machine = OpcUaMachine(trace, free_port(), space=_slash_space)
    machine.start()
    try:
        errors, stderr = refused(tmp_path, _source(machine.url))
    finally:
        machine.stop()
    assert len(errors) == 1, stderr[-2000:]
    assert errors[0].startswith(
        "rcb: error: opcua.nodes.spindle_load = 'CNC:CncInterface/CNC:CncSpindleList/Spindle/"
        "CNC:ActLoad': the server has no namespace http://opcfoundation.org/UA/CNC (CNC:); it "
        "has 0=http://opcfoundation.org/UA/, "
    ), errors
    assert "2=http://opcfoundation.org/UA/CNC/" in errors[0]
