"""Part reports: what the MES sends after a part, as frozen objects.

A report names the part, the setpoint version it was made with, and per operation the
measured quantities, each with its expanded (±2σ) uncertainty, as Ivester & Heigel Table 5
prints them ("horizontal and vertical bars are ±2σ measurement uncertainties", Fig. 4).

A report is read and checked once, at the edge: the REST body's schema
(:class:`api.rest.schemas.parts.PartReportIn`, and ``parse_report`` for JSON-like data from
elsewhere). These objects keep only their invariants; whether the operations and quantities
exist in the plan is checked by :func:`supervisor.rcb.update.update`, which refuses the whole
report before applying any of it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

from models.errors import InputError

#: Coverage factor of a reported (expanded) uncertainty: ``σ = U / 2`` (GUM 6.2-6.3; Ivester &
#: Heigel Table 5's ±2σ).
COVERAGE_FACTOR = 2.0
#: The least expanded uncertainty a reading is counted with, as a fraction of its value [-]:
#: half the tightest of Ivester & Heigel Table 5 (a force read to ±2 N, 0.1 % of the paper's
#: 2000 N force limit). A chain that states less (its resolution given as its uncertainty, a
#: near-zero by mistake) is counted at this: ``learn`` took a reading stated to 1e-9 N as
#: exact, its posterior lost its positive definiteness (numerically) and it set setpoints past
#: the limits or failed on every later report (:func:`counted`).
LEAST_REL_UNCERTAINTY = 5e-4


@dataclass(frozen=True)
class Measurement:
    """A measured value and its expanded uncertainty ``±uncertainty`` (same unit, ≈ 2σ).

    ``σ = uncertainty /`` :data:`COVERAGE_FACTOR`.
    """

    value: float
    uncertainty: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.value) and self.value >= 0):
            raise InputError("value", self.value, "must be a finite number >= 0")
        if not (math.isfinite(self.uncertainty) and self.uncertainty >= 0):
            raise InputError("uncertainty", self.uncertainty, "must be a finite number >= 0")


def counted(measurement: Measurement) -> Measurement:
    """``measurement`` with its uncertainty at least :data:`LEAST_REL_UNCERTAINTY` of its value."""
    least = LEAST_REL_UNCERTAINTY * measurement.value
    if measurement.uncertainty >= least:
        return measurement
    return replace(measurement, uncertainty=least)


@dataclass(frozen=True)
class ToolWear:
    """Flank wear of the edge an operation uses, measured after it removed ``volume_mm3``.

    Parameters
    ----------
    flank_wear_mm : Measurement
        Average flank wear VB and its uncertainty [mm] (Ivester & Heigel, "Tool Life Model").
    volume_mm3 : float
        Volume the edge has removed since it was new [mm³].
    """

    flank_wear_mm: Measurement
    volume_mm3: float


@dataclass(frozen=True)
class Signal:
    """A raw spindle reading to be converted to ``force_N`` by a machine calibration.

    Parameters
    ----------
    quantity : str
        ``spindle_load_V`` or ``spindle_current_A`` (:data:`models.sensors.RAW_QUANTITIES`).
    reading : Measurement
        The reading and its expanded uncertainty [V] or [A].
    context : Mapping[str, float]
        What the conversion needs and the report knows better than the setpoint
        (``spindle_speed_rpm``, ``idle_load_V`` ..., :data:`SIGNAL_CONTEXT`).
    calibration : str or None
        Name of the machine calibration to use; None: the machine's only one for the quantity.
    """

    quantity: str
    reading: Measurement
    context: Mapping[str, float] = field(default_factory=dict)
    calibration: str | None = None


#: What a raw reading may carry besides value and uncertainty (:func:`models.sensors.to_force`).
SIGNAL_CONTEXT = (
    "spindle_speed_rpm",
    "workpiece_diameter_mm",
    "u_workpiece_diameter_mm",
    "idle_load_V",
    "u_idle_load_V",
    "feed_rate_mm_min",
    "u_feed_rate_mm_min",
)


@dataclass(frozen=True)
class PartReport:
    """What the MES reports after one part.

    Parameters
    ----------
    serial : str
        Part serial number.
    setpoint_version : int
        The setpoint version the part was made with.
    measurements : Mapping[str, Mapping[str, Measurement]]
        Per operation name, the measured quantities (``force_N``, ``roughness_um`` ...).
    tool_wear : Mapping[str, ToolWear]
        Per operation name, a flank-wear measurement of its edge, when one was taken.
    signals : Mapping[str, Mapping[str, Signal]]
        Per operation name, raw spindle readings (``spindle_load_V``; ``spindle_current_A``
        with context or a named calibration) that :mod:`supervisor.inputs.signals` converts to
        ``force_N`` before RCB.
    feed_overrides : Mapping[str, float]
        Per operation name under constant-load control, the feed override at the end of the
        operation [% of the programmed feed rate] (Tai et al.: the tool is changed when the
        feed it commands falls to the lower feed limit).
    edge_parts : Mapping[str, int]
        Per operation name, the parts its cutting edge made before this one (0: a new edge),
        as a control's tool-life counter gives it; the ``learn`` strategy learns wear from it.
    """

    serial: str
    setpoint_version: int
    measurements: Mapping[str, Mapping[str, Measurement]] = field(default_factory=dict)
    tool_wear: Mapping[str, ToolWear] = field(default_factory=dict)
    signals: Mapping[str, Mapping[str, Signal]] = field(default_factory=dict)
    feed_overrides: Mapping[str, float] = field(default_factory=dict)
    edge_parts: Mapping[str, int] = field(default_factory=dict)
