"""The ``collector.toml`` that reads the virtual lathe (``rcb virtual serve --collector FILE``).

Everything in it follows from the served machine: its URL, its program's operation map, the
plan's spindle-load calibration, the setpoint version its parts are made with; the service URL
and plan id are given. The API key is read by ``rcb collect`` from ``RCB_API_KEY`` (never in
the file). The text is checked with the collector's own reader before it is written, so it is
never one ``rcb collect`` refuses.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

from api.collect.config import config_from_mapping
from api.virtual_serve.lathe import CALIBRATION, SETPOINT_VERSION, VirtualLathe
from models.errors import InputError

#: Expanded (k = 2) uncertainty of one reading [V]: the trace's noise is 0.004 V (one sigma).
UNCERTAINTY_V = 0.02


def _quoted(text: str) -> str:
    return json.dumps(text)  # a TOML basic string is a JSON string for these characters


def collector_toml(
    lathe: VirtualLathe,
    protocol: str,
    url: str,
    service: tuple[str, int],
    machine: str,
    queue: str,
) -> str:
    """The file's text: ``service`` is the REST service's URL and the plan's id."""
    service_url, plan_id = service
    operations = ", ".join(_quoted(m) for m in lathe.operation_map())
    lines = [
        f"# rcb collect --config this file: reads the virtual lathe at {url}",
        "[collector]",
        f"machine = {_quoted(machine)}",
        f"queue = {_quoted(queue)}",
        "[service]",
        f"url = {_quoted(service_url)}",
        f"plan = {plan_id}",
        f"setpoint_version = {SETPOINT_VERSION}  # every part of rcb virtual serve is made at it",
        'api_key_env = "RCB_API_KEY"',
        "[signal]",
        'quantity = "spindle_load_V"',
        f"uncertainty = {UNCERTAINTY_V}",
        f"calibration = {_quoted(CALIBRATION)}",
        f"operations = [{operations}]",
    ]
    if protocol == "mtconnect":
        lines += ["[mtconnect]", f"url = {_quoted(url)}", "poll_s = 0.2"]
    else:
        lines += [
            "[opcua]",
            f"url = {_quoted(url)}",
            "[opcua.nodes]  # what OPC 40502 does not place: under Objects/Machine",
            'part_count = "Machine/PartCount"',
            'tool_number = "Machine/ToolNumber"',
            'program = "Machine/ProgramName"',
        ]
    return "\n".join(lines) + "\n"


def queue_name(path: Path) -> str:
    """The queue of the collector whose file is ``path`` (``collector-queue.sqlite``)."""
    return f"{path.stem}-queue.sqlite"


def write_collector(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` once it reads as a collector's file."""
    config_from_mapping(tomllib.loads(text), path.parent)
    try:
        path.write_text(text, encoding="utf-8")
    except OSError as err:
        raise InputError("--collector", str(path), f"cannot be written ({err.strerror})") from None
