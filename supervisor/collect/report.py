"""A finished part → the part report the REST service takes, its serial and Idempotency-Key.

Each pass's reading goes as a raw spindle reading (``spindle_load_V`` or ``spindle_current_A``)
with its expanded uncertainty, the machine calibration that converts it and the measured spindle
speed and feed rate; the service converts it to ``force_N`` with the calibration's propagated
uncertainty (:func:`supervisor.inputs.signals.resolve`, :func:`models.sensors.to_force`; the idle
load from the calibration's spindle-speed table at the measured speed) and stores the reading
beside the force. The serial and the key follow from the plan, machine, program and part count
only, so a part collected again after a restart is the same request: the service stores it once.
"""

from __future__ import annotations

import hashlib
from typing import Any
from urllib.parse import quote

from models.bounds import MAX_IDENTITY
from models.sensors import RAW_QUANTITIES
from supervisor.collect.segment import PartDone

#: The longest Idempotency-Key the service takes (visible ASCII).
MAX_KEY = 255
#: The longest serial the service takes (:data:`models.bounds.MAX_IDENTITY`).
MAX_SERIAL = MAX_IDENTITY


def serial_of(machine: str, program: str, part_count: int) -> str:
    """``lathe-1/O1001/17``: the part's serial (hashed past 200 characters)."""
    text = f"{machine}/{program}/{part_count}"
    if len(text) <= MAX_SERIAL:
        return text
    return f"{machine[:60]}/{hashlib.sha256(text.encode()).hexdigest()}/{part_count}"


def idempotency_key(plan_id: int, machine: str, program: str, part_count: int) -> str:
    """``rcb-collect:3:lathe-1:O1001:17`` (percent-encoded; a SHA-256 past 255 characters).

    The plan is part of the key: the service scopes keys to the API key, not to the plan, and a
    machine that moves to another plan starts its program's count again.
    """
    names = f"{quote(machine, safe='')}:{quote(program, safe='')}"
    key = f"rcb-collect:{plan_id}:{names}:{part_count}"
    if len(key) <= MAX_KEY:
        return key
    return "rcb-collect:sha256:" + hashlib.sha256(key.encode()).hexdigest()


def part_report(
    part: PartDone,
    *,
    machine: str,
    setpoint_version: int,
    quantity: str,
    uncertainty: float,
    calibration: str | None,
) -> tuple[dict[str, Any], list[str]]:
    """The report body (``POST /plans/{id}/parts``) and the passes left out, with why.

    Parameters
    ----------
    part : PartDone
        The part.
    machine : str
        The machine's name (in the serial).
    setpoint_version : int
        The setpoint version the program was written with (``rcb gcode`` prints it).
    quantity : str
        ``spindle_load_V`` or ``spindle_current_A``.
    uncertainty : float
        Expanded (k = 2) uncertainty of one reading [V or A].
    calibration : str or None
        The machine calibration to convert with (None: the machine's only one for it).
    """
    if quantity not in RAW_QUANTITIES:
        raise ValueError(f"quantity {quantity!r} is not one of {RAW_QUANTITIES}")
    operations, left_out = [], []
    for p in part.passes:
        if p.value <= uncertainty:
            left_out.append(f"{p.operation}: reading {p.value:.6g} not above its uncertainty")
            continue
        reading: dict[str, Any] = {"value": p.value, "uncertainty": uncertainty}
        if calibration is not None:
            reading["calibration"] = calibration
        if p.spindle_speed_rpm is not None and p.spindle_speed_rpm > 0:
            reading["spindle_speed_rpm"] = p.spindle_speed_rpm
        if p.feed_rate_mm_min is not None and p.feed_rate_mm_min > 0:
            reading["feed_rate_mm_min"] = p.feed_rate_mm_min
        operations.append({"name": p.operation, "measurements": {quantity: reading}})
    left_out += [f"{name}: no load sample while ACTIVE" for name in part.missing]
    body = {
        "serial": serial_of(machine, part.program, part.part_count),
        "setpoint_version": setpoint_version,
        "operations": operations,
    }
    return body, left_out
