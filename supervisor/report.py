"""Part reports: what the MES sends after a part, as frozen objects.

A report names the part, the setpoint version it was made with, and per operation the
measured quantities, each with its expanded (±2σ) uncertainty, as Ivester & Heigel Table 5
prints them ("horizontal and vertical bars are ±2σ measurement uncertainties", Fig. 4).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from models.errors import InputError


@dataclass(frozen=True)
class Measurement:
    """A measured value and its expanded uncertainty ``±uncertainty`` (same unit, ≈ 2σ)."""

    value: float
    uncertainty: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.value) and self.value >= 0):
            raise InputError("value", self.value, "must be a finite number >= 0")
        if not (math.isfinite(self.uncertainty) and self.uncertainty >= 0):
            raise InputError("uncertainty", self.uncertainty, "must be a finite number >= 0")


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
    """

    serial: str
    setpoint_version: int
    measurements: Mapping[str, Mapping[str, Measurement]] = field(default_factory=dict)
    tool_wear: Mapping[str, ToolWear] = field(default_factory=dict)
