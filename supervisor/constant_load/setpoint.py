"""The constant-load part of a milling setpoint: reference current and feed-rate limits.

A milling operation may run under constant-load control (Tai et al. §II.A-B): the machine holds
the spindle current at a reference by a feed override, between a lower and an upper feed
limit, and the tool is changed when the feed falls to the lower limit. The plan gives, per
operation, ``[operations.constant_load]``:

- ``calibration``: the name of the machine's ``tai_current_feed`` calibration (Eq. 14),
- ``max_current_A``: the largest current the tool withstood (§III.A),
- ``safety_factor`` (0.85) and ``wear_interval_um`` ([180, 220], §II.G), optional.

Each setpoint then carries the reference current and the feed limits of
:func:`~supervisor.constant_load.limits_from_calibration`, with one rule joining the two loops:
the upper feed limit is never above the robust setpoint's programmed feed rate ``fz·z·n``. The
robust optimum is the fastest feed whose force, roughness and machine loads stay inside their
limits at the band edge; the inner loop may slow down from it as the tool wears, never speed up
past it. As RCB shrinks the bands the programmed feed, and with it the upper limit, rises up to
the current's own limit (Eq. 13). When the programmed feed is at or below the lower limit the
current cannot reach the reference before the wear interval is passed, so the feed cannot time
the tool change: ``tool_change_by_feed`` is then false, both limits are the programmed feed
(the operation runs at constant feed) and edges must be changed by count.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

from models import fields
from models.errors import InputError
from models.sensors import TaiCurrentFeedCalibration
from supervisor.constant_load.limits import (
    PAPER_SAFETY_FACTOR,
    PAPER_WEAR_INTERVAL_MM,
    ConstantLoadSetup,
    limits_from_calibration,
)

_KEYS = ("calibration", "max_current_A", "safety_factor", "wear_interval_um")


@dataclass(frozen=True)
class ConstantLoadConfig:
    """``[operations.constant_load]`` of a milling operation.

    Parameters
    ----------
    calibration : str
        Name of the machine's ``tai_current_feed`` calibration.
    max_current_A : float
        Largest spindle current the tool withstood [A].
    safety_factor : float
        Fraction of it held as the reference current [-].
    wear_interval_mm : tuple[float, float]
        Flank wear interval at tool change, sharp end first [mm].
    """

    calibration: str
    max_current_A: float
    safety_factor: float = PAPER_SAFETY_FACTOR
    wear_interval_mm: tuple[float, float] = PAPER_WEAR_INTERVAL_MM


@dataclass(frozen=True)
class ConstantLoadSetpoint:
    """Reference current and feed limits of one milling setpoint.

    Parameters
    ----------
    reference_current_A : float
        The spindle current the inner loop holds [A].
    feed_rate_upper_mm_min : float
        Upper feed limit [mm/min]: the lesser of Eq. 13's and the programmed feed rate.
    feed_rate_lower_mm_min : float
        Lower feed limit [mm/min] (Eq. 15 at the worn end of the interval, with its band):
        the tool is changed when the feed falls to it; the programmed feed when that is lower.
    programmed_feed_rate_mm_min : float
        The robust setpoint's feed rate ``fz·z·n`` [mm/min].
    upper_governed_by : {"current", "setpoint"}
        Whether the current (Eq. 13) or the programmed feed set the upper limit.
    tool_change_by_feed : bool
        Whether the feed can time the tool change (the programmed feed is above the lower
        limit).
    wear_interval_mm : tuple[float, float]
        The tool-change wear interval [mm].
    """

    reference_current_A: float
    feed_rate_upper_mm_min: float
    feed_rate_lower_mm_min: float
    programmed_feed_rate_mm_min: float
    upper_governed_by: Literal["current", "setpoint"]
    tool_change_by_feed: bool
    wear_interval_mm: tuple[float, float]


def config_from_mapping(
    data: object, path: str, calibrations: Mapping[str, object]
) -> ConstantLoadConfig:
    """Read ``[operations.constant_load]``; every error names the dotted field and value.

    Parameters
    ----------
    data : object
        The table, as parsed from TOML or JSON.
    path : str
        Its dotted path, for errors.
    calibrations : Mapping[str, object]
        The machine's calibrations by name.
    """
    table = fields.mapping(data, path)
    fields.only_keys(table, _KEYS, path)
    name = fields.text(table, "calibration", path)
    if name not in calibrations:
        known = ", ".join(sorted(calibrations)) or "none"
        raise InputError(f"{path}.calibration", name, f"machine has no such calibration: {known}")
    if not isinstance(calibrations[name], TaiCurrentFeedCalibration):
        kind = getattr(calibrations[name], "kind", None)
        raise InputError(
            f"{path}.calibration", name, f"is a {kind} calibration; needs tai_current_feed"
        )
    if "max_current_A" not in table:
        raise InputError(f"{path}.max_current_A", None, "required field missing")
    max_current = fields.number(table["max_current_A"], f"{path}.max_current_A", positive=True)
    factor = PAPER_SAFETY_FACTOR
    if "safety_factor" in table:
        factor = fields.number(table["safety_factor"], f"{path}.safety_factor", positive=True)
        if factor > 1:
            raise InputError(f"{path}.safety_factor", factor, "must be in (0, 1]")
    interval = PAPER_WEAR_INTERVAL_MM
    if "wear_interval_um" in table:
        raw = table["wear_interval_um"]
        where = f"{path}.wear_interval_um"
        if isinstance(raw, str | bytes) or not isinstance(raw, list | tuple) or len(raw) != 2:
            raise InputError(where, raw, "must be [sharp end, worn end] in µm")
        lo = fields.number(raw[0], f"{where}[0]", minimum=0.0)
        hi = fields.number(raw[1], f"{where}[1]", positive=True)
        if lo > hi:
            raise InputError(where, raw, "reversed: the sharp end comes first")
        interval = (lo / 1000.0, hi / 1000.0)
    return ConstantLoadConfig(name, max_current, factor, interval)


def setup_of(
    config: ConstantLoadConfig, calibration: TaiCurrentFeedCalibration
) -> ConstantLoadSetup:
    """The reference current and feed limits the configuration gives with its calibration."""
    return limits_from_calibration(
        calibration,
        max_current_A=config.max_current_A,
        safety_factor=config.safety_factor,
        wear_interval_mm=config.wear_interval_mm,
    )


def constant_load_setpoint(
    setup: ConstantLoadSetup, programmed_feed_rate_mm_min: float
) -> ConstantLoadSetpoint:
    """The constant-load part of a setpoint whose programmed feed rate is given [mm/min]."""
    upper = setup.upper.feed_rate_mm_min
    lower = setup.lower.feed_rate_mm_min
    programmed = programmed_feed_rate_mm_min
    governed: Literal["current", "setpoint"] = "current" if upper <= programmed else "setpoint"
    return ConstantLoadSetpoint(
        reference_current_A=setup.reference_current_A,
        feed_rate_upper_mm_min=min(upper, programmed),
        feed_rate_lower_mm_min=min(lower, upper, programmed),
        programmed_feed_rate_mm_min=programmed,
        upper_governed_by=governed,
        tool_change_by_feed=programmed > lower,
        wear_interval_mm=setup.wear_interval_mm,
    )
