"""An MTConnect agent's streams → observations: ``/current`` then ``/sample?from=&count=``.

MTConnectStreams documents (MTConnect Standard Part 1, "Protocol"; the Streams model of Part 3)
are read with their namespace, whatever its version (``urn:mtconnect.org:MTConnectStreams:2.x``).
Each observation (an element under ``Samples``, ``Events`` or ``Condition`` of a
``ComponentStream``) carries the agent's ``sequence``; the header gives ``instanceId``,
``firstSequence``, ``lastSequence`` and ``nextSequence``. The data item of each signal is chosen
once, from the agent's device model (``/probe``, :mod:`api.collect.mtconnect_devices`: the
spindle's own ``LOAD``, never an override as a rate, the declared units), and observations are
read by their ``dataItemId``, converted to the signal's unit. ``UNAVAILABLE`` is no value.

A ``from`` older than the agent's buffer is answered with an ``MTConnectError`` document
(``OUT_OF_RANGE``): :class:`AgentError`; the runner reports the lost sequences as a gap.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Collection, Mapping
from dataclasses import dataclass

import httpx

from api.collect.mtconnect_devices import Bound, Device, bind, parse_devices, with_modes
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


def _value(item: str, text: str | None, scale: float = 1.0) -> float | int | str | None:
    if text is None or text.strip() == "UNAVAILABLE":
        return None
    text = text.strip()
    try:
        if item in _NUMERIC:
            number = float(text) * scale
            return number if math.isfinite(number) else None
        if item in _WHOLE:
            return int(float(text))
    except ValueError:
        return None
    if item == "block":
        return block_number(text)
    return text


def _root(document: bytes, expected: str = "MTConnectStreams") -> tuple[ET.Element, str]:
    """The root of an MTConnect document and its namespace (``{urn...}``).

    Raises
    ------
    AgentError
        An MTConnectError document, or a document whose root is not ``expected``.
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
    if _local(root.tag) != expected:
        raise AgentError("NOT_STREAMS", f"root element {_local(root.tag)}, not {expected}")
    return root, namespace


def _elements(root: ET.Element, namespace: str) -> list[ET.Element]:
    """Every observation of the document (under Samples, Events, Condition)."""
    found: list[ET.Element] = []
    for component in root.iter(f"{namespace}ComponentStream"):
        for category in _CATEGORIES:
            holder = component.find(f"{namespace}{category}")
            if holder is not None:
                found.extend(holder)
    return found


def latest_values(document: bytes, ids: Collection[str]) -> dict[str, str]:
    """The last value of each data item of ``ids`` in a streams document (``/current``)."""
    root, namespace = _root(document)
    return {
        e.get("dataItemId", ""): (e.text or "").strip()
        for e in _elements(root, namespace)
        if e.get("dataItemId") in ids
    }


def parse_streams(document: bytes, binding: Mapping[str, Bound]) -> Streams:
    """Read an MTConnectStreams document; ``binding`` gives each signal's data item and scale.

    Raises
    ------
    AgentError
        An MTConnectError document, or a document that is not MTConnectStreams.
    """
    root, namespace = _root(document)
    header = root.find(f"{namespace}Header")
    if header is None:
        raise AgentError("NO_HEADER", "MTConnectStreams without a Header")
    by_id = {b.item.id: b for b in binding.values()}
    found: list[Observation] = []
    for element in _elements(root, namespace):
        bound = by_id.get(element.get("dataItemId", ""))
        if bound is None:
            continue
        sequence = int(element.get("sequence", "0"))
        value = _value(bound.signal, element.text, bound.scale)
        found.append(Observation(sequence, bound.signal, value))
    found.sort(key=lambda o: o.sequence)
    return Streams(
        instance_id=header.get("instanceId", ""),
        first_sequence=int(header.get("firstSequence", "0")),
        last_sequence=int(header.get("lastSequence", "0")),
        next_sequence=int(header.get("nextSequence", "0")),
        observations=tuple(found),
    )


class Agent:
    """An agent over HTTP (httpx): ``bind()`` once, then ``current()`` and ``sample()``."""

    def __init__(
        self,
        http: httpx.AsyncClient,
        url: str,
        items: Mapping[str, str],
        *,
        spindle: str | None = None,
        required: tuple[str, ...] = (),
    ) -> None:
        self.http, self.url, self.items = http, url, items
        self.spindle, self.required = spindle, required
        self.binding: dict[str, Bound] = {}

    async def _text(self, path: str, params: Mapping[str, int] | None = None) -> bytes:
        answer = await self.http.get(f"{self.url}/{path}", params=params)
        if answer.status_code >= 500:
            answer.raise_for_status()
        return answer.content

    async def _get(self, path: str, params: Mapping[str, int] | None = None) -> Streams:
        return parse_streams(await self._text(path, params), self.binding)

    async def bind(self) -> dict[str, Bound]:
        """Read the device model (``/probe``) and choose the data item of every signal.

        Raises
        ------
        InputError
            A signal the agent does not offer (required), only offers as an override, or
            offers more than once.
        """
        probe = await self._text("probe")
        _root(probe, "MTConnectDevices")  # an agent's error document: AgentError
        device: Device = parse_devices(probe)
        if device.rotary_modes:  # a Rotary whose mode may change: in spindle mode now?
            modes = latest_values(await self._text("current"), tuple(device.rotary_modes))
            device = with_modes(device, modes)
        self.binding = bind(device, self.items, spindle=self.spindle, required=self.required)
        return self.binding

    async def current(self) -> Streams:
        """``GET /current``: the latest value of every data item."""
        return await self._get("current")

    async def sample(self, start: int, count: int) -> Streams:
        """``GET /sample?from=start&count=count``: observations from ``start`` on."""
        return await self._get("sample", {"from": start, "count": count})
