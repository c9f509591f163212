"""An MTConnect agent's streams → observations: ``/current`` then ``/sample?from=&count=``.

MTConnectStreams documents (MTConnect Standard Part 1, "Protocol"; the Streams model of Part 3)
are read with their namespace, whatever its version (``urn:mtconnect.org:MTConnectStreams:2.x``).
Each observation (an element under ``Samples``, ``Events`` or ``Condition`` of a
``ComponentStream``) carries the agent's ``sequence``; the header gives ``instanceId``,
``firstSequence``, ``lastSequence`` and ``nextSequence``. A data item is chosen as
``Component/Type`` (the ComponentStream's ``component`` and the element's name, e.g.
``Rotary/Load``) or by its ``dataItemId``. ``UNAVAILABLE`` is no value.

A ``from`` older than the agent's buffer is answered with an ``MTConnectError`` document
(``OUT_OF_RANGE``): :class:`AgentError`; the runner reports the lost sequences as a gap.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass

import httpx

from supervisor.collect.segment import Observation
from supervisor.collect.selectors import block_number

_NUMERIC = ("spindle_load", "spindle_speed_rpm", "feed_rate_mm_min")
_WHOLE = ("part_count", "tool_number")
_CATEGORIES = ("Samples", "Events", "Condition")


class AgentError(Exception):
    """The agent answered an MTConnectError document (``code``: its ``errorCode``)."""

    def __init__(self, code: str, text: str) -> None:
        super().__init__(f"MTConnect agent error {code}: {text}")
        self.code, self.text = code, text


@dataclass(frozen=True)
class Streams:
    """An MTConnectStreams document: its header and the chosen observations by sequence."""

    instance_id: str
    first_sequence: int
    last_sequence: int
    next_sequence: int
    observations: tuple[Observation, ...]


def _local(tag: str) -> str:
    return tag.rpartition("}")[2]


def _value(item: str, text: str | None) -> float | int | str | None:
    if text is None or text.strip() == "UNAVAILABLE":
        return None
    text = text.strip()
    try:
        if item in _NUMERIC:
            number = float(text)
            return number if math.isfinite(number) else None
        if item in _WHOLE:
            return int(float(text))
    except ValueError:
        return None
    if item == "block":
        return block_number(text)
    return text


def parse_streams(document: bytes, items: Mapping[str, str]) -> Streams:
    """Read an MTConnectStreams document; ``items`` maps each signal to its data item.

    Raises
    ------
    AgentError
        An MTConnectError document, or a document that is not MTConnectStreams.
    """
    try:
        root = ET.fromstring(document)
    except ET.ParseError as err:
        raise AgentError("NOT_XML", str(err)) from None
    namespace = root.tag.partition("}")[0] + "}" if root.tag.startswith("{") else ""
    if _local(root.tag) == "MTConnectError":
        errors = root.findall(f".//{namespace}Error")
        code = errors[0].get("errorCode", "UNKNOWN") if errors else "UNKNOWN"
        text = "; ".join((e.text or "").strip() for e in errors)
        raise AgentError(code, text)
    if _local(root.tag) != "MTConnectStreams":
        raise AgentError("NOT_STREAMS", f"root element {_local(root.tag)}")
    header = root.find(f"{namespace}Header")
    if header is None:
        raise AgentError("NO_HEADER", "MTConnectStreams without a Header")
    by_id = {v: k for k, v in items.items() if "/" not in v}
    by_type = {tuple(v.split("/", 1)): k for k, v in items.items() if "/" in v}
    found: list[Observation] = []
    for component in root.iter(f"{namespace}ComponentStream"):
        kind = component.get("component", "")
        for category in _CATEGORIES:
            holder = component.find(f"{namespace}{category}")
            if holder is None:
                continue
            for element in holder:
                item = by_id.get(element.get("dataItemId", "")) or by_type.get(
                    (kind, _local(element.tag))
                )
                if item is None:
                    continue
                sequence = int(element.get("sequence", "0"))
                found.append(Observation(sequence, item, _value(item, element.text)))
    found.sort(key=lambda o: o.sequence)
    return Streams(
        instance_id=header.get("instanceId", ""),
        first_sequence=int(header.get("firstSequence", "0")),
        last_sequence=int(header.get("lastSequence", "0")),
        next_sequence=int(header.get("nextSequence", "0")),
        observations=tuple(found),
    )


class Agent:
    """An agent over HTTP (httpx): ``current()`` and ``sample(from, count)``."""

    def __init__(self, http: httpx.AsyncClient, url: str, items: Mapping[str, str]) -> None:
        self.http, self.url, self.items = http, url, items

    async def _get(self, path: str, params: Mapping[str, int] | None = None) -> Streams:
        answer = await self.http.get(f"{self.url}/{path}", params=params)
        if answer.status_code >= 500:
            answer.raise_for_status()
        return parse_streams(answer.content, self.items)

    async def current(self) -> Streams:
        """``GET /current``: the latest value of every data item."""
        return await self._get("current")

    async def sample(self, start: int, count: int) -> Streams:
        """``GET /sample?from=start&count=count``: observations from ``start`` on."""
        return await self._get("sample", {"from": start, "count": count})
