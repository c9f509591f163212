"""An asyncua address space built from the OPC Foundation's own nodesets (from npm, at test time).

The nodesets of ``node-opcua-nodesets`` (:mod:`npm_packages`) are imported as published
(``import_xml(..., strict_mode=False)``): OPC 40502 CNC Systems (``Opc.Ua.CNC.NodeSet.xml``) and
OPC 40501 Machine Tools (``Opc.Ua.MachineTool.NodeSet2.xml``) with what it requires (DI, IA,
Machinery, ISA-95 job control, Machinery Jobs). The instances are made from the imported types,
so every BrowseName and namespace is the specification's, none typed here:

- ``Objects/CNC:CncInterface`` of ``CncInterfaceType``; in its ``CncSpindleList`` a
  ``Spindle`` of ``CncSpindleType`` (``ActLoad``, ``ActSpeed``), in its ``CncChannelList`` a
  ``Channel`` of ``CncChannelType`` (``ActStatus``, ``ActFeedrate``, ``ActProgramBlock`` a
  String[3], ``ToolId``);
- ``Objects/Machines/Lathe`` of ``MachineToolType``: the program name at
  ``MT:Production/MT:ActiveProgram/MT:Name``;
- the part count, which neither specification places, at ``Objects/Lathe/PartCount`` in the
  test's own namespace.
"""

from __future__ import annotations

from pathlib import Path

from asyncua import Server, ua

from api.virtual_serve.opcua_machine import Nodes
from supervisor.virtual.trace import TraceSample

CNC = "http://opcfoundation.org/UA/CNC"
MACHINE_TOOL = "http://opcfoundation.org/UA/MachineTool/"
MACHINERY = "http://opcfoundation.org/UA/Machinery/"
#: In the order they depend on each other.
NODESETS = (
    "Opc.Ua.CNC.NodeSet.xml",
    "Opc.Ua.Di.NodeSet2.xml",
    "Opc.Ua.IA.NodeSet2.xml",
    "Opc.Ua.Machinery.NodeSet2.xml",
    "opc.ua.isa95-jobcontrol.nodeset2.xml",
    "Opc.Ua.Machinery.Jobs.Nodeset2.xml",
    "Opc.Ua.MachineTool.NodeSet2.xml",
)
#: ``[opcua.nodes]`` of a collector reading this space: what the default paths do not cover.
COLLECTOR_NODES = {
    "part_count": "Lathe/PartCount",
    "tool_number": "CNC:CncInterface/CNC:CncChannelList/Channel/CNC:ToolId",
    "program": "Machines/Lathe/MT:Production/MT:ActiveProgram/MT:Name",
}


async def _type(server: Server, uri: str, name: str) -> ua.NodeId:
    """The NodeId of the ObjectType ``name`` of namespace ``uri``, found by browsing."""
    index = await server.get_namespace_index(uri)
    pending = [server.nodes.base_object_type]
    while pending:
        node = pending.pop()
        for child in await node.get_children(refs=ua.ObjectIds.HasSubtype):
            browse = await child.read_browse_name()
            if browse.Name == name and browse.NamespaceIndex == index:
                return child.nodeid
            pending.append(child)
    raise LookupError(f"no ObjectType {name} in {uri}")


class OfficialSpace:
    """``space`` for the virtual lathe's ``OpcUaMachine``: the nodesets of ``folder``."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder

    async def __call__(self, server: Server, first: TraceSample) -> Nodes:
        for name in NODESETS:
            await server.import_xml(str(self.folder / name), strict_mode=False)
        cnc = await server.get_namespace_index(CNC)
        mt = await server.get_namespace_index(MACHINE_TOOL)
        own = await server.register_namespace("urn:rcb-supervisor:test-lathe")
        interface = await server.nodes.objects.add_object(
            cnc, "CncInterface", objecttype=await _type(server, CNC, "CncInterfaceType")
        )
        spindles = await interface.get_child(f"{cnc}:CncSpindleList")
        spindle = await spindles.add_object(
            own, "Spindle", objecttype=await _type(server, CNC, "CncSpindleType")
        )
        channels = await interface.get_child(f"{cnc}:CncChannelList")
        channel = await channels.add_object(
            own, "Channel", objecttype=await _type(server, CNC, "CncChannelType")
        )
        machines = await server.nodes.objects.get_child(
            f"{await server.get_namespace_index(MACHINERY)}:Machines"
        )
        lathe = await machines.add_object(
            own, "Lathe", objecttype=await _type(server, MACHINE_TOOL, "MachineToolType")
        )
        program = await lathe.get_child([f"{mt}:Production", f"{mt}:ActiveProgram", f"{mt}:Name"])
        counter = await server.nodes.objects.add_object(own, "Lathe")
        part_count = await counter.add_variable(
            own, "PartCount", ua.Variant(first.part_count, ua.VariantType.UInt32)
        )
        found = {
            "execution": (channel, "ActStatus", ua.VariantType.Int32, False),
            "tool_number": (channel, "ToolId", ua.VariantType.UInt32, False),
            "block": (channel, "ActProgramBlock", ua.VariantType.String, True),
            "spindle_speed_rpm": (spindle, "ActSpeed", ua.VariantType.Double, False),
            "feed_rate_mm_min": (channel, "ActFeedrate", ua.VariantType.Double, False),
            "spindle_load": (spindle, "ActLoad", ua.VariantType.Double, False),
        }
        nodes: Nodes = {
            "program": (program, ua.VariantType.String, False),
            "part_count": (part_count, ua.VariantType.UInt32, False),
        }
        for item, (parent, name, kind, array) in found.items():
            nodes[item] = (await parent.get_child(f"{cnc}:{name}"), kind, array)
        return nodes
