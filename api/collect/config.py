"""``collector.toml``: one machine, one plan, one signal, one protocol (see README "rcb collect").

Every error names the field and its value (:class:`models.errors.InputError`). Secrets are never
in the file: the API key and an OPC UA password are read from the environment variables the file
names, and neither is ever logged or shown by ``--status``.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from api.collect.tls import ca_file
from models.bounds import (
    LARGEST,
    LARGEST_WHOLE,
    MAX_OPERATIONS,
    SMALLEST_MEASURED,
    check_count,
)
from models.errors import InputError
from models.fields import number_within, only_keys, table, text_within, whole_within
from models.sensors import RAW_QUANTITIES
from supervisor.collect.selectors import OperationSelector, check_selectors, parse_selector
from supervisor.inputs.files import read_toml

#: MTConnect data items read by default: ``Component/Type`` (:mod:`api.collect.mtconnect_devices`:
#: ``Rotary`` is the spindle, ``Path`` the path or else the controller).
MTCONNECT_ITEMS: dict[str, str] = {
    "spindle_load": "Rotary/Load",
    "spindle_speed_rpm": "Rotary/RotaryVelocity",
    "feed_rate_mm_min": "Path/PathFeedrate",
    "block": "Path/Block",
    "tool_number": "Path/ToolNumber",
    "part_count": "Path/PartCount",
    "execution": "Path/Execution",
    "program": "Path/Program",
}
#: Where a collector without a checkpoint starts reading an agent: its next sequence (parts made
#: from now on) or the oldest observation in its buffer (the parts it still holds).
MTCONNECT_STARTS = ("next", "buffer")
#: OPC UA nodes read by default: browse paths from ``Objects`` with the BrowseNames of OPC 40502
#: (CNC Systems: ``CncInterface``, ``CncSpindleList``/``CncChannelList``, ``ActLoad``,
#: ``ActSpeed``, ``ActFeedrate``, ``ActProgramBlock``, ``ActStatus``); ``{spindle}`` and
#: ``{channel}`` are the instances' BrowseNames from ``[opcua]``. The companion specifications
#: define no part counter, tool number or program name at a fixed path: give those.
OPCUA_NODES: dict[str, str] = {
    "spindle_load": "CNC:CncInterface/CNC:CncSpindleList/{spindle}/CNC:ActLoad",
    "spindle_speed_rpm": "CNC:CncInterface/CNC:CncSpindleList/{spindle}/CNC:ActSpeed",
    "feed_rate_mm_min": "CNC:CncInterface/CNC:CncChannelList/{channel}/CNC:ActFeedrate",
    "block": "CNC:CncInterface/CNC:CncChannelList/{channel}/CNC:ActProgramBlock",
    "execution": "CNC:CncInterface/CNC:CncChannelList/{channel}/CNC:ActStatus",
}
#: Namespace URIs of the prefixes a browse path may use, exactly as the OPC Foundation's nodesets
#: publish them (``<NamespaceUris>`` of ``Opc.Ua.CNC.NodeSet.xml``, OPC 40502 1.0: no trailing
#: slash; of ``Opc.Ua.MachineTool.NodeSet2.xml``, OPC 40501 1.02: with one).
OPCUA_PREFIXES = {
    "CNC": "http://opcfoundation.org/UA/CNC",
    "MT": "http://opcfoundation.org/UA/MachineTool/",
}
#: OPC 40502 CncChannelStatus: Reset 0, Interrupted 1, Active 2.
OPCUA_ACTIVE = ("2",)
REQUIRED_OPCUA = ("spindle_load", "part_count")
#: Most characters of a text field (a URL, a name, a path, a variable's name).
MAX_FIELD_TEXT = 500


@dataclass(frozen=True)
class MTConnectConfig:
    """An agent: base URL (with the device, e.g. ``http://agent:5000/lathe-1``)."""

    url: str
    items: Mapping[str, str]
    count: int = 1000
    poll_s: float = 0.2
    spindle: str | None = None  # the spindle component's name or id; default: found by its mode
    start: str = "next"  # without a checkpoint: "next" (new observations) or "buffer" (oldest)
    ca_file: Path | None = None  # the CA to trust for an https url (api.collect.tls)


@dataclass(frozen=True)
class OpcUaConfig:
    """A server: endpoint, security, user, and the node of every signal."""

    url: str
    nodes: Mapping[str, str]
    active_values: tuple[str, ...] = OPCUA_ACTIVE
    security: str | None = None
    username: str | None = None
    password_env: str | None = None
    publishing_ms: float = 50.0
    queue_size: int = 10000

    def __repr__(self) -> str:  # never print the password's variable's value, only its name
        return f"OpcUaConfig(url={self.url!r}, username={self.username!r}, security=...)"


@dataclass(frozen=True)
class CollectorConfig:
    """The whole ``collector.toml``."""

    machine: str
    queue_path: Path
    service_url: str
    plan_id: int
    setpoint_version: int
    api_key_env: str
    quantity: str
    uncertainty: float
    calibration: str | None
    percentile: float
    selectors: tuple[OperationSelector, ...]
    mtconnect: MTConnectConfig | None = None
    opcua: OpcUaConfig | None = None
    retry_max_s: float = 5.0
    service_ca_file: Path | None = None  # the CA to trust for an https url (api.collect.tls)

    def api_key(self) -> str:
        """The API key from the environment (never stored, never logged)."""
        key = os.environ.get(self.api_key_env, "")
        if not key:
            raise InputError("service.api_key_env", self.api_key_env, "environment variable unset")
        return key


def load_config(path: Path) -> CollectorConfig:
    """Read and check ``collector.toml``; relative paths are relative to its folder.

    Read as every TOML file the CLI reads (:func:`supervisor.inputs.files.read_toml`: at most
    :data:`models.bounds.MAX_DOCUMENT_BYTES`); errors name ``--config``.
    """
    data = read_toml(path, "--config")
    if not isinstance(data, Mapping):  # tomllib always gives a table; for mypy
        raise InputError("--config", str(path), "is not a TOML table")
    return config_from_mapping(data, path.parent)


def config_from_mapping(data: Mapping[str, Any], base: Path) -> CollectorConfig:
    """Check a parsed ``collector.toml`` (see :func:`load_config`)."""
    only_keys(
        data, ("collector", "service", "signal", "mtconnect", "opcua"), "", list_allowed=False
    )
    collector, service, signal = (table(data, key) for key in ("collector", "service", "signal"))
    only_keys(collector, ("machine", "queue", "retry_max_s"), "collector", list_allowed=False)
    only_keys(
        service,
        ("url", "plan", "setpoint_version", "api_key_env", "ca_file"),
        "service",
        list_allowed=False,
    )
    keys = ("quantity", "uncertainty", "calibration", "percentile", "operations")
    only_keys(signal, keys, "signal", list_allowed=False)
    quantity = text_within(signal, "quantity", "signal", "spindle_load_V", most=MAX_FIELD_TEXT)
    if quantity not in RAW_QUANTITIES:
        raise InputError("signal.quantity", quantity, f"must be one of {', '.join(RAW_QUANTITIES)}")
    operations = signal.get("operations")
    if not isinstance(operations, list) or not all(isinstance(o, str) for o in operations):
        raise InputError("signal.operations", operations, "must be a list of OP=N100:N200 or OP=T1")
    check_count(len(operations), MAX_OPERATIONS, "signal.operations", "operations")
    selectors = tuple(parse_selector(o, "signal.operations") for o in operations)
    check_selectors(selectors, "signal.operations")
    if ("mtconnect" in data) == ("opcua" in data):
        raise InputError("mtconnect", None, "give exactly one of [mtconnect] and [opcua]")
    queue = Path(
        text_within(collector, "queue", "collector", "collector-queue.sqlite", most=MAX_FIELD_TEXT)
    )
    calibration = _text(signal, "calibration", "signal")
    url = text_within(service, "url", "service", most=MAX_FIELD_TEXT)
    if not url.startswith(("http://", "https://")):
        raise InputError("service.url", url, "must start with http:// or https://")
    return CollectorConfig(
        machine=text_within(collector, "machine", "collector", most=MAX_FIELD_TEXT),
        queue_path=queue if queue.is_absolute() else base / queue,
        service_url=url.rstrip("/"),
        plan_id=whole_within(service, "plan", "service", most=LARGEST_WHOLE),
        setpoint_version=whole_within(service, "setpoint_version", "service", most=LARGEST_WHOLE),
        api_key_env=text_within(
            service, "api_key_env", "service", "RCB_API_KEY", most=MAX_FIELD_TEXT
        ),
        quantity=quantity,
        uncertainty=number_within(
            signal, "uncertainty", "signal", low=SMALLEST_MEASURED, high=LARGEST
        ),
        calibration=calibration,
        percentile=number_within(
            signal, "percentile", "signal", low=1e-9, high=100.0, default=100.0
        ),
        selectors=selectors,
        mtconnect=_mtconnect(data["mtconnect"], base) if "mtconnect" in data else None,
        opcua=_opcua(data["opcua"]) if "opcua" in data else None,
        retry_max_s=number_within(
            collector, "retry_max_s", "collector", low=0.01, high=3600.0, default=5.0
        ),
        service_ca_file=ca_file(_text(service, "ca_file", "service"), "service", url, base),
    )


def _text(data: Mapping[str, Any], key: str, section: str) -> str | None:
    """An optional text field (None: not given)."""
    return None if data.get(key) is None else text_within(data, key, section, most=MAX_FIELD_TEXT)


def _items(data: object, path: str, known: tuple[str, ...]) -> dict[str, str]:
    if data is None:
        return {}
    if not isinstance(data, Mapping):
        raise InputError(path, data, "must be a table of signal = source")
    for key, value in data.items():
        if key not in known:
            raise InputError(f"{path}.{key}", value, f"unknown signal; known: {', '.join(known)}")
        if not isinstance(value, str) or not value.strip():
            raise InputError(f"{path}.{key}", value, "must be text")
    return dict(data)


def _mtconnect(data: object, base: Path) -> MTConnectConfig:
    if not isinstance(data, Mapping):
        raise InputError("mtconnect", data, "must be a table")
    only_keys(
        data,
        ("url", "count", "poll_s", "data_items", "spindle", "start", "ca_file"),
        "mtconnect",
        list_allowed=False,
    )
    url = text_within(data, "url", "mtconnect", most=MAX_FIELD_TEXT)
    if not url.startswith(("http://", "https://")):
        raise InputError("mtconnect.url", url, "must start with http:// or https://")
    items = {**MTCONNECT_ITEMS, **_items(data.get("data_items"), "mtconnect.data_items", _ITEMS)}
    spindle = _text(data, "spindle", "mtconnect")
    start = data.get("start", "next")
    if start not in MTCONNECT_STARTS:
        raise InputError("mtconnect.start", start, f"must be one of {', '.join(MTCONNECT_STARTS)}")
    return MTConnectConfig(
        url=url.rstrip("/"),
        items=items,
        spindle=spindle,
        start=start,
        count=whole_within(data, "count", "mtconnect", most=100_000, default=1000),
        poll_s=number_within(data, "poll_s", "mtconnect", low=0.001, high=60.0, default=0.2),
        ca_file=ca_file(_text(data, "ca_file", "mtconnect"), "mtconnect", url, base),
    )


def _opcua(data: object) -> OpcUaConfig:
    if not isinstance(data, Mapping):
        raise InputError("opcua", data, "must be a table")
    keys = ("url", "nodes", "spindle", "channel", "active_values", "security", "username")
    only_keys(
        data, (*keys, "password_env", "publishing_ms", "queue_size"), "opcua", list_allowed=False
    )
    url = text_within(data, "url", "opcua", most=MAX_FIELD_TEXT)
    if not url.startswith("opc.tcp://"):
        raise InputError("opcua.url", url, "must start with opc.tcp://")
    spindle = text_within(data, "spindle", "opcua", "Spindle", most=MAX_FIELD_TEXT)
    channel = text_within(data, "channel", "opcua", "Channel", most=MAX_FIELD_TEXT)
    defaults = {k: v.format(spindle=spindle, channel=channel) for k, v in OPCUA_NODES.items()}
    nodes = {**defaults, **_items(data.get("nodes"), "opcua.nodes", _ITEMS)}
    for key in REQUIRED_OPCUA:
        if key not in nodes:
            raise InputError(f"opcua.nodes.{key}", None, "required: no companion-spec default")
    active = data.get("active_values", list(OPCUA_ACTIVE))
    if not isinstance(active, list) or not active:
        raise InputError("opcua.active_values", active, "must be a list of values")
    username = _text(data, "username", "opcua")
    security = _text(data, "security", "opcua")
    password_env = _text(data, "password_env", "opcua")
    return OpcUaConfig(
        url=url,
        nodes=nodes,
        active_values=tuple(str(a) for a in active),
        security=security,
        username=username,
        password_env=password_env,
        publishing_ms=number_within(
            data, "publishing_ms", "opcua", low=1.0, high=60_000.0, default=50.0
        ),
        queue_size=whole_within(data, "queue_size", "opcua", most=1_000_000, default=10000),
    )


_ITEMS = tuple(MTCONNECT_ITEMS)
