"""An MTConnect agent's device model (``/probe``) → the data item of every signal, with its unit.

An MTConnectDevices document (MTConnect Standard Part 2, "Devices"), of any version (1.0's
``urn:mtconnect.com`` as well as ``urn:mtconnect.org:MTConnectDevices:1.x/2.x``), declares each
data item with its ``type``, ``subType``, ``category`` and ``units`` (the unit of the values an
agent streams; ``nativeUnits`` when no ``units`` are given, the Standard's unit of the type when
neither is), inside the component it belongs to. A signal of ``[mtconnect.data_items]`` is a
``dataItemId`` or ``Component/Type``:

- ``Type`` is the streams element (``Load``, ``PathFeedrate``) or the device type (``LOAD``);
  1.x and 2.x names are both accepted (``RotaryVelocity`` is also ``SPINDLE_SPEED``,
  ``ToolNumber`` also ``TOOL_ID``).
- ``Component`` is a component's ``name`` or ``id`` (``C``, ``path1``), or a kind:
  ``Rotary``/``Spindle`` is *the spindle*: a 1.x ``Spindle``, or the ``Rotary`` whose
  ``ROTARY_MODE`` is ``SPINDLE`` (its only allowed value, or its current value), or the
  component ``[mtconnect] spindle`` names; never another axis's ``LOAD``. ``Path`` is the
  path, else the controller (1.x agents put ``Block`` under ``Controller``), else any component.

A feed rate or a spindle speed is never an override (``subType="OVERRIDE"`` or units
``PERCENT``), a rapid or a jog rate; among the rest ``ACTUAL`` comes first, then no subType,
then ``COMMANDED``, then ``PROGRAMMED``. Values are converted to the signal's unit (a feed rate in
``MILLIMETER/SECOND`` × 60 → mm/min). Whatever cannot be bound is an
:class:`models.errors.InputError` naming the field and what the agent offers.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass

from models.errors import InputError

#: The device types each signal may be read from (1.x and 2.x names).
TYPES: dict[str, tuple[str, ...]] = {
    "spindle_load": ("LOAD",),
    "spindle_speed_rpm": ("ROTARY_VELOCITY", "SPINDLE_SPEED"),
    "feed_rate_mm_min": ("PATH_FEEDRATE",),
    "block": ("BLOCK",),
    "tool_number": ("TOOL_NUMBER", "TOOL_ID"),
    "part_count": ("PART_COUNT",),
    "execution": ("EXECUTION",),
    "program": ("PROGRAM",),
}
#: subTypes a signal may be read from, best first ("" = none).
SUBTYPES: dict[str, tuple[str, ...]] = {
    "spindle_load": ("ACTUAL", ""),
    "spindle_speed_rpm": ("ACTUAL", "", "COMMANDED", "PROGRAMMED"),
    "feed_rate_mm_min": ("ACTUAL", "", "COMMANDED", "PROGRAMMED"),
    "part_count": ("", "ALL", "COMPLETE", "GOOD"),
    "program": ("", "MAIN", "ACTIVE"),
}
#: Signal units: factor from each unit an agent may stream to the signal's unit; the first is
#: the Standard's unit for the type (Part 2, DataItem types), assumed when none is declared.
UNITS: dict[str, dict[str, float]] = {
    "spindle_speed_rpm": {"REVOLUTION/MINUTE": 1.0, "REVOLUTION/SECOND": 60.0},
    "feed_rate_mm_min": {
        "MILLIMETER/SECOND": 60.0,
        "MILLIMETER/MINUTE": 1.0,
        "INCH/MINUTE": 25.4,
        "INCH/SECOND": 25.4 * 60.0,
        "FOOT/MINUTE": 304.8,
    },
}
SPINDLE_SIGNALS = ("spindle_load", "spindle_speed_rpm")
_SPINDLE_KINDS = ("Rotary", "Spindle")


@dataclass(frozen=True)
class DataItem:
    """A ``DataItem`` of the device, with the component it belongs to."""

    id: str
    type: str
    sub_type: str
    category: str
    units: str
    component_kind: str  # the component's element: Rotary, Spindle, Path, Controller, ...
    component_name: str  # its name, else its id
    component_id: str

    def describe(self) -> str:
        """``c4 (C/LOAD ACTUAL, PERCENT)`` for a message or the log."""
        sub = f" {self.sub_type}" if self.sub_type else ""
        unit = f", {self.units}" if self.units else ""
        return f"{self.id} ({self.component_name}/{self.type}{sub}{unit})"


@dataclass(frozen=True)
class Bound:
    """A signal bound to a data item: values are multiplied by ``scale`` (1 for text)."""

    signal: str
    item: DataItem
    scale: float = 1.0


@dataclass(frozen=True)
class Device:
    """The data items of one device, and which ``Rotary``/``Spindle`` components are spindles."""

    name: str
    items: tuple[DataItem, ...]
    spindles: tuple[str, ...]  # component names
    rotary_modes: Mapping[str, str]  # an unconstrained ROTARY_MODE's id → its component's name


def _local(tag: str) -> str:
    return tag.rpartition("}")[2]


def _snake(name: str) -> str:
    """``PathFeedrate`` → ``PATH_FEEDRATE`` (a streams element's name → its device type)."""
    return name if name.isupper() else re.sub(r"(?<!^)(?=[A-Z])", "_", name).upper()


def parse_devices(document: bytes) -> Device:
    """The one device of an MTConnectDevices document (``GET {device url}/probe``)."""
    try:
        root = ET.fromstring(document)
    except ET.ParseError as err:
        raise InputError("mtconnect.url", "/probe", f"not XML ({err})") from None
    if _local(root.tag) != "MTConnectDevices":
        raise InputError("mtconnect.url", "/probe", f"not MTConnectDevices: {_local(root.tag)}")
    devices = [e for e in root.iter() if _local(e.tag) == "Device"]
    if len(devices) != 1:
        names = ", ".join(d.get("name", "?") for d in devices) or "none"
        raise InputError("mtconnect.url", "/probe", f"one device expected, found {names}")
    items: list[DataItem] = []
    spindles: list[str] = []
    modes: dict[str, str] = {}

    def walk(component: ET.Element) -> None:
        kind = _local(component.tag)
        name = component.get("name") or component.get("id") or ""
        for child in component:
            if _local(child.tag) == "DataItems":
                for e in child:
                    if _local(e.tag) != "DataItem":
                        continue
                    item = DataItem(
                        id=e.get("id", ""),
                        type=e.get("type", ""),
                        sub_type=e.get("subType", ""),
                        category=e.get("category", ""),
                        units=e.get("units") or e.get("nativeUnits") or "",
                        component_kind=kind,
                        component_name=name,
                        component_id=component.get("id", ""),
                    )
                    items.append(item)
                    if item.type == "ROTARY_MODE":
                        allowed = [v.text or "" for v in e.iter() if _local(v.tag) == "Value"]
                        if allowed == ["SPINDLE"]:
                            spindles.append(name)
                        elif not allowed:
                            modes[item.id] = name
            elif _local(child.tag) == "Components":
                for sub in child:
                    walk(sub)
        if kind == "Spindle":
            spindles.append(name)

    walk(devices[0])
    return Device(devices[0].get("name", ""), tuple(items), tuple(spindles), modes)


def with_modes(device: Device, current: Mapping[str, str]) -> Device:
    """``device`` with the Rotary components whose current ``ROTARY_MODE`` is ``SPINDLE``."""
    now = [name for id_, name in device.rotary_modes.items() if current.get(id_) == "SPINDLE"]
    spindles = tuple(dict.fromkeys((*device.spindles, *now)))
    return Device(device.name, device.items, spindles, device.rotary_modes)


def _wanted_type(signal: str, text: str) -> tuple[str, ...]:
    kind = _snake(text)
    for names in TYPES.values():  # a 1.x or a 2.x name: either of the pair
        if kind in names:
            return names if names == TYPES[signal] else (kind,)
    return (kind,)


def _candidates(
    device: Device, signal: str, spec: str, spindle: str | None, field: str
) -> list[DataItem]:
    where, _, kind_text = spec.partition("/")
    kinds = _wanted_type(signal, kind_text)
    typed = [i for i in device.items if i.type in kinds]
    named = [i for i in typed if where in (i.component_name, i.component_id)]
    if named or where not in (*_SPINDLE_KINDS, "Path"):
        return named
    if where in _SPINDLE_KINDS:
        rotaries = sorted(
            {i.component_name for i in device.items if i.component_kind in _SPINDLE_KINDS}
        )
        if spindle is not None:
            if not any(spindle in (i.component_name, i.component_id) for i in device.items):
                offered = ", ".join(rotaries) or "none"
                raise InputError("mtconnect.spindle", spindle, f"no such component: {offered}")
            return [i for i in typed if spindle in (i.component_name, i.component_id)]
        if not device.spindles:
            offered = ", ".join(rotaries) or "none"
            raise InputError(
                field,
                spec,
                "no spindle on the agent (no Spindle, no Rotary in ROTARY_MODE SPINDLE): name "
                f"it in mtconnect.spindle; Rotary/Spindle components: {offered}",
            )
        return [i for i in typed if i.component_name in device.spindles]
    for kinds_first in (("Path",), ("Controller",)):  # the path, else the controller, else any
        found = [i for i in typed if i.component_kind in kinds_first]
        if found:
            return found
    return typed


def bind(
    device: Device,
    items: Mapping[str, str],
    *,
    spindle: str | None = None,
    required: tuple[str, ...] = (),
) -> dict[str, Bound]:
    """The data item of every signal of ``items`` (``signal → dataItemId or Component/Type``).

    A signal of ``required`` the agent does not offer is an input error; another is left out
    (its reports carry no such value). A feed rate or a spindle speed whose only items are
    overrides is an input error, never read as a rate.
    """
    bound: dict[str, Bound] = {}
    for signal, spec in items.items():
        field = f"mtconnect.data_items.{signal}"
        if "/" in spec:
            found = _candidates(device, signal, spec, spindle, field)
        else:
            found = [i for i in device.items if i.id == spec]
        if signal in _NUMERIC:
            found = [i for i in found if i.category == "SAMPLE"]
        rates = [i for i in found if not _override(i)] if signal in UNITS else found
        if found and not rates:
            offered = ", ".join(i.describe() for i in found)
            raise InputError(field, spec, f"only an override on the agent ({offered}), no rate")
        chosen = _best(signal, spec, rates, field)
        if chosen is None:
            if signal in required:
                raise InputError(field, spec, f"not on the agent's device {device.name!r}")
            continue
        bound[signal] = Bound(signal, chosen, _scale(signal, chosen, field))
    return bound


_NUMERIC = ("spindle_load", "spindle_speed_rpm", "feed_rate_mm_min")


def _override(item: DataItem) -> bool:
    return item.sub_type in ("OVERRIDE", "RAPID", "JOG") or item.units == "PERCENT"


def _best(signal: str, spec: str, found: list[DataItem], field: str) -> DataItem | None:
    order = SUBTYPES.get(signal)
    if order is not None:
        found = [i for i in found if i.sub_type in order]
    if len({i.component_id for i in found}) > 1:  # two spindles, two paths: never a guess
        offered = ", ".join(i.describe() for i in found)
        raise InputError(field, spec, f"ambiguous: {offered}; name the component or the item")
    if order is not None:
        rank = {i.id: order.index(i.sub_type) for i in found}
        best = min(rank.values(), default=0)
        found = [i for i in found if rank[i.id] == best]
    if len(found) > 1:
        offered = ", ".join(i.describe() for i in found)
        raise InputError(field, spec, f"ambiguous: {offered}; give the dataItemId")
    return found[0] if found else None


def _scale(signal: str, item: DataItem, field: str) -> float:
    units = UNITS.get(signal)
    if units is None:
        return 1.0
    unit = item.units or next(iter(units))
    if unit not in units:
        raise InputError(field, item.describe(), f"units {unit} not one of {', '.join(units)}")
    return units[unit]
