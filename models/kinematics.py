"""Turning and milling kinematics as monomials in the cutting parameters.

Each relation is a :class:`~models.monomial.Monomial`, so the optimiser can use it as a
log-linear constraint, and each has a plain function for callers with numbers.

References
----------
.. [1] Ivester & Heigel, Eq. 10 (removal rate ``v·f·d``) and Eq. 3 (torque = force × radius).
.. [2] Sandvik Coromant, Metal cutting formulas (turning: ``n = 1000 vc/(π Dm)``,
   ``Q = vc·ap·fn``, ``Pc = Fc·vc/60000``; milling: ``vf = fz·zc·n``, ``Q = ap·ae·vf/1000``).
"""

from __future__ import annotations

import math
from typing import Literal

from models.monomial import Monomial

Process = Literal["turning", "milling"]
PROCESSES: tuple[Process, ...] = ("turning", "milling")

#: Decision variables of each process, in the optimiser's order.
PARAMETERS: dict[Process, tuple[str, ...]] = {
    "turning": ("depth_mm", "feed_mm_rev", "speed_m_min"),
    "milling": ("axial_depth_mm", "radial_depth_mm", "feed_per_tooth_mm", "speed_m_min"),
}

#: Fixed inputs of each process (geometry and the tool-wear criterion).
CONTEXT: dict[Process, tuple[str, ...]] = {
    "turning": ("workpiece_diameter_mm", "flank_wear_mm"),
    "milling": ("tool_diameter_mm", "flute_count", "flank_wear_mm"),
}
#: Flank-wear criterion when an operation gives none: VB = 0.3 mm (ISO 3685:1993, 7.2).
DEFAULT_FLANK_WEAR_MM = 0.3

#: Diameter on which spindle speed and torque depend.
DIAMETER: dict[Process, str] = {
    "turning": "workpiece_diameter_mm",
    "milling": "tool_diameter_mm",
}

_RPM = 1000.0 / math.pi


def spindle_rpm_monomial(process: Process) -> Monomial:
    """Spindle speed ``n = 1000 v / (π D)`` [rpm] with v [m/min] and D [mm]."""
    return Monomial(_RPM, {"speed_m_min": 1.0, DIAMETER[process]: -1.0})


def feed_rate_monomial(process: Process) -> Monomial:
    """Feed rate [mm/min]: ``f·n`` (turning) or ``fz·z·n`` (milling)."""
    if process == "turning":
        return spindle_rpm_monomial(process) * Monomial(1.0, {"feed_mm_rev": 1.0})
    return spindle_rpm_monomial(process) * Monomial(
        1.0, {"feed_per_tooth_mm": 1.0, "flute_count": 1.0}
    )


def mrr_monomial(process: Process) -> Monomial:
    """Material removal rate [cm³/min]: ``d·f·v`` (turning) or ``ap·ae·vf/1000`` (milling)."""
    if process == "turning":
        return Monomial(1.0, {"depth_mm": 1.0, "feed_mm_rev": 1.0, "speed_m_min": 1.0})
    return feed_rate_monomial(process) * Monomial(
        1e-3, {"axial_depth_mm": 1.0, "radial_depth_mm": 1.0}
    )


def machining_time_min(volume_mm3: float, mrr_cm3_min: float) -> float:
    """Time to remove ``volume_mm3`` [mm³] at ``mrr_cm3_min`` [cm³/min]: ``V / (1000 Q)`` [min]."""
    return volume_mm3 / (1000.0 * mrr_cm3_min)


def power_per_newton_monomial() -> Monomial:
    """Cutting power per newton of cutting force, ``v / 60000`` [kW/N] with v [m/min]."""
    return Monomial(1.0 / 60000.0, {"speed_m_min": 1.0})


def torque_per_newton_monomial(process: Process) -> Monomial:
    """Spindle torque per newton of cutting force, ``D / 2000`` [N·m/N] with D [mm]."""
    return Monomial(1.0 / 2000.0, {DIAMETER[process]: 1.0})


def turning_spindle_rpm(speed_m_min: float, diameter_mm: float) -> float:
    """Spindle speed [rpm] for surface speed ``speed_m_min`` [m/min] on ``diameter_mm`` [mm]."""
    return spindle_rpm_monomial("turning").evaluate(
        {"speed_m_min": speed_m_min, "workpiece_diameter_mm": diameter_mm}
    )


def turning_mrr_cm3_min(depth_mm: float, feed_mm_rev: float, speed_m_min: float) -> float:
    """Turning removal rate ``d·f·v`` [cm³/min] (Ivester & Heigel Eq. 10)."""
    return mrr_monomial("turning").evaluate(
        {"depth_mm": depth_mm, "feed_mm_rev": feed_mm_rev, "speed_m_min": speed_m_min}
    )


def milling_mrr_cm3_min(
    axial_depth_mm: float,
    radial_depth_mm: float,
    feed_per_tooth_mm: float,
    speed_m_min: float,
    tool_diameter_mm: float,
    flute_count: int,
) -> float:
    """Milling removal rate ``ap·ae·fz·z·n/1000`` [cm³/min]."""
    return mrr_monomial("milling").evaluate(
        {
            "axial_depth_mm": axial_depth_mm,
            "radial_depth_mm": radial_depth_mm,
            "feed_per_tooth_mm": feed_per_tooth_mm,
            "speed_m_min": speed_m_min,
            "tool_diameter_mm": tool_diameter_mm,
            "flute_count": float(flute_count),
        }
    )


def cutting_power_kW(force_N: float, speed_m_min: float) -> float:
    """Cutting power ``F·v/60000`` [kW] for force [N] and surface speed [m/min]."""
    return force_N * power_per_newton_monomial().evaluate({"speed_m_min": speed_m_min})


def spindle_torque_Nm(force_N: float, diameter_mm: float) -> float:
    """Spindle torque ``F·D/2000`` [N·m] for force [N] at diameter [mm] (Ivester Eq. 3)."""
    return force_N * torque_per_newton_monomial("turning").evaluate(
        {"workpiece_diameter_mm": diameter_mm}
    )
