"""Browse paths and NodeIds of ``[opcua.nodes]`` → a server's nodes, or one input error.

A node is a NodeId (``ns=2;s=Spindle.Load``, ``nsu=...;i=...``) or a browse path from
``Objects``: ``CNC:CncInterface/CNC:CncSpindleList/Spindle/CNC:ActLoad``, each segment a
BrowseName with an optional prefix (``CNC``, ``MT``: the namespace URIs of OPC 40502 and OPC
40501 as their nodesets publish them, :data:`api.collect.config.OPCUA_PREFIXES`; a number: a
namespace index; none: any namespace). Whatever cannot be resolved is an
:class:`models.errors.InputError` naming the field, the path, the segment and what the server
offers there (its namespaces, or the BrowseNames under the last node found), never a raw
``ValueError`` of the client.
"""

from __future__ import annotations

from typing import Any

from api.collect.config import OPCUA_PREFIXES
from models.errors import InputError

_NODE_ID = ("ns=", "nsu=", "i=", "s=", "g=", "b=")
#: How many BrowseNames an error lists before it says how many more there are.
_SHOWN = 12


def _prefixed(index: int, name: str, namespaces: list[str]) -> str:
    """``CNC:ActLoad`` for a known namespace, else ``2:Name`` (the index), for a message."""
    uri = namespaces[index] if index < len(namespaces) else ""
    for prefix, known in OPCUA_PREFIXES.items():
        if uri == known:
            return f"{prefix}:{name}"
    return f"{index}:{name}"


def _listing(names: list[str]) -> str:
    if not names:
        return "nothing"
    more = f" and {len(names) - _SHOWN} more" if len(names) > _SHOWN else ""
    return ", ".join(sorted(names)[:_SHOWN]) + more


async def _node_id(client: Any, spec: str, field: str) -> Any:
    from asyncua.ua.status_codes import StatusCodes
    from asyncua.ua.uaerrors import UaStatusCodeError, UaStringParsingError

    try:
        node = client.get_node(spec)
    except (UaStringParsingError, ValueError) as err:
        raise InputError(field, spec, f"not a NodeId ({err.args[0]})") from None
    try:
        await node.read_browse_name()
    except UaStatusCodeError as err:
        if err.code in (StatusCodes.BadNodeIdUnknown, StatusCodes.BadNodeIdInvalid):
            raise InputError(field, spec, "the server has no node with this NodeId") from None
        raise
    return node


async def resolve(client: Any, spec: str, field: str) -> Any:
    """The node a NodeId string or a browse path names (see the module docstring).

    Raises
    ------
    InputError
        An unknown prefix, a namespace the server does not have, a segment with no node, or a
        NodeId the server does not know: the message names the path and what the server offers.
    """
    if spec.startswith(_NODE_ID):
        return await _node_id(client, spec, field)
    namespaces: list[str] = list(await client.get_namespace_array())
    node, where = client.nodes.objects, "Objects"
    for segment in spec.split("/"):
        prefix, _, name = segment.rpartition(":")
        index: int | None = None
        if prefix in OPCUA_PREFIXES:
            uri = OPCUA_PREFIXES[prefix]
            if uri not in namespaces:
                listed = ", ".join(f"{i}={u}" for i, u in enumerate(namespaces))
                raise InputError(
                    field, spec, f"the server has no namespace {uri} ({prefix}:); it has {listed}"
                )
            index = namespaces.index(uri)
        elif prefix.isdigit():
            index = int(prefix)
        elif prefix:
            known = ", ".join(OPCUA_PREFIXES)
            raise InputError(
                field, spec, f"unknown prefix {prefix!r} in {segment!r}: use {known} or an index"
            )
        offered: list[str] = []
        for child in await node.get_children():
            browse = await child.read_browse_name()
            if browse.Name == name and (index is None or browse.NamespaceIndex == index):
                node, where = child, f"{where}/{segment}"
                break
            offered.append(_prefixed(browse.NamespaceIndex, browse.Name, namespaces))
        else:
            raise InputError(
                field, spec, f"no node {segment!r} under {where}; it has {_listing(offered)}"
            )
    return node
