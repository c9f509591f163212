"""Ivester & Heigel (NIST): spindle load → torque → cutting force on a lathe, Eqs. 1-4.

Eqs. 1-2 give the ratio ``m`` of torque to spindle load as a function of spindle speed, Eq. 3
the cutting force ``F = m·(L − L_idle)/D`` and Eq. 4 its uncertainty; :func:`ivester_load_V`
inverts Eq. 3.

Units of Eq. 3: ``m`` [N·mm/V] · ``L`` [V] / ``D`` [mm] = N. The text calls ``m`` "the ratio
between torque and spindle load", but Eq. 3 divides by the diameter, not the radius, so ``m`` is
twice the torque per volt (torque ``F·D/2``); :func:`ivester_force_N` applies Eq. 3 as printed,
since Eqs. 1-3 are the fitted model. See :func:`ivester_spindle_torque_Nm`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from models import fields
from models.errors import InputError, ModelDomainError
from models.sensors.converted import Converted

_RAD_S_PER_RPM = 2.0 * math.pi / 60.0


def rpm_to_rad_s(speed_rpm: float) -> float:
    """Angular speed [rad/s] of a spindle turning at ``speed_rpm`` [rpm]: ``2π n / 60``."""
    return speed_rpm * _RAD_S_PER_RPM


@dataclass(frozen=True)
class IvesterSpindleLoadCalibration:
    r"""The spindle load → cutting force model of Ivester & Heigel, Eqs. 1-3, with its provenance.

    .. math::

        m(\phi) = \begin{cases} m_\text{low} & \phi \le \phi_c \quad \text{(Eq. 1)} \\
                  c\,\phi^{e} & \phi > \phi_c \quad \text{(Eq. 2)} \end{cases}, \qquad
        F = \frac{m\,(L - L_\text{idle}(\phi))}{D} \quad \text{(Eq. 3)}

    Parameters
    ----------
    m_low_N_mm_per_V : float
        Ratio ``m`` up to the corner speed [N·mm/V] (Eq. 1: 2.19e5).
    m_coefficient : float
        Coefficient ``c`` of the power law above the corner speed [N·mm/V at 1 rad/s]
        (Eq. 2: 1.39e8).
    m_exponent : float
        Exponent ``e`` of the spindle speed in rad/s [-] (Eq. 2: -1.52).
    corner_speed_rad_s : float
        Speed up to which ``m`` is constant [rad/s] (Eqs. 1-2: 70.2).
    u_m_N_mm_per_V : float
        Standard uncertainty of ``m`` [N·mm/V]. Default 210: the paper's ``Δm = ±0.21``
        (a ±2s value) read as N·m/V of torque ``F·D/2`` per volt (Figure 1), i.e. 420 N·mm/V
        of Eq. 3's ``m``, halved. The paper does not print the unit of ``Δm``.
    idle_speeds_rpm, idle_loads_V : tuple of float
        Idle load measured without cutting at these spindle speeds [rpm] and [V]; the paper
        subtracts "the idle load measured at the same spindle speed without cutting".
        Linear interpolation in speed, no extrapolation. Empty: the idle load must be given
        with each reading.
    u_idle_load_V : float
        Standard uncertainty of a tabulated idle load [V].
    source, reference, date, notes : str
        Provenance.
    """

    kind: ClassVar[str] = "ivester_spindle_load"

    m_low_N_mm_per_V: float = 2.19e5
    m_coefficient: float = 1.39e8
    m_exponent: float = -1.52
    corner_speed_rad_s: float = 70.2
    u_m_N_mm_per_V: float = 210.0
    idle_speeds_rpm: tuple[float, ...] = ()
    idle_loads_V: tuple[float, ...] = ()
    u_idle_load_V: float = 0.0
    source: str = "Ivester & Heigel (NIST), 22 kW lathe, AISI 1045"
    reference: str = "Eqs. 1-4; Δm = ±0.21 (±2s) in the text after Eq. 3"
    date: str = ""
    notes: str = ""

    def __post_init__(self) -> None:
        fields.check_field(self, "m_low_N_mm_per_V", positive=True)
        fields.check_field(self, "m_coefficient", positive=True)
        fields.check_field(self, "m_exponent")
        fields.check_field(self, "corner_speed_rad_s", minimum=0.0)
        fields.check_field(self, "u_m_N_mm_per_V", minimum=0.0)
        fields.check_field(self, "u_idle_load_V", minimum=0.0)
        speeds = fields.number_list(self.idle_speeds_rpm, "idle_speeds_rpm", positive=True)
        loads = fields.number_list(self.idle_loads_V, "idle_loads_V", minimum=0.0)
        if len(speeds) != len(loads):
            raise InputError(
                "idle_loads_V", self.idle_loads_V, f"needs one load per speed ({len(speeds)})"
            )
        if len(speeds) == 1:
            raise InputError("idle_speeds_rpm", self.idle_speeds_rpm, "needs at least 2 speeds")
        if any(b <= a for a, b in zip(speeds, speeds[1:], strict=False)):
            raise InputError("idle_speeds_rpm", self.idle_speeds_rpm, "must be increasing")
        object.__setattr__(self, "idle_speeds_rpm", speeds)
        object.__setattr__(self, "idle_loads_V", loads)


#: Ivester & Heigel's lathe (Eqs. 1-2), without an idle-load table (the paper prints none).
IVESTER_SPINDLE_LOAD = IvesterSpindleLoadCalibration()


def ivester_ratio_N_mm_per_V(
    speed_rad_s: float, calibration: IvesterSpindleLoadCalibration = IVESTER_SPINDLE_LOAD
) -> float:
    r"""Ratio ``m`` of Eq. 3 at a spindle speed (Ivester & Heigel Eqs. 1 and 2).

    .. math:: m = 2.19\cdot10^5 \; (\phi \le 70.2\ \text{rad/s}), \qquad
              m = 1.39\cdot10^8\,\phi^{-1.52} \; (\phi > 70.2\ \text{rad/s})

    Parameters
    ----------
    speed_rad_s : float
        Spindle speed ``φ`` [rad/s].
    calibration : IvesterSpindleLoadCalibration
        The constants (default: the paper's).

    Returns
    -------
    float
        ``m`` [N·mm/V]. As printed, the two branches do not meet: Eq. 2 gives 2.171e5 at
        70.2 rad/s, 0.9 % below Eq. 1.

    References
    ----------
    .. [1] Ivester & Heigel, Eqs. 1-2 and Figure 2.
    """
    speed = fields.number(speed_rad_s, "speed_rad_s", minimum=0.0)
    if speed <= calibration.corner_speed_rad_s:
        return calibration.m_low_N_mm_per_V
    return float(calibration.m_coefficient * speed**calibration.m_exponent)


def _ivester_idle(
    calibration: IvesterSpindleLoadCalibration, speed_rpm: float, speed_field: str
) -> Converted:
    speeds, loads = calibration.idle_speeds_rpm, calibration.idle_loads_V
    if not speeds:
        raise InputError("idle_load_V", None, "required: the calibration has no idle-load table")
    if not speeds[0] <= speed_rpm <= speeds[-1]:
        raise ModelDomainError(
            speed_field,
            speed_rpm,
            f"outside the idle-load table ({speeds[0]:g} to {speeds[-1]:g} rpm)",
        )
    return Converted(float(np.interp(speed_rpm, speeds, loads)), calibration.u_idle_load_V)


def ivester_idle_load_V(
    spindle_speed_rpm: float, calibration: IvesterSpindleLoadCalibration
) -> Converted:
    """Idle spindle load at a speed, from the calibration's table (Ivester & Heigel, Eq. 3 text).

    Parameters
    ----------
    spindle_speed_rpm : float
        Spindle speed [rpm], within the table.
    calibration : IvesterSpindleLoadCalibration
        A calibration with an idle-load table.

    Returns
    -------
    Converted
        Idle load [V], linearly interpolated, and its standard uncertainty [V].
    """
    speed = fields.number(spindle_speed_rpm, "spindle_speed_rpm", positive=True)
    return _ivester_idle(calibration, speed, "spindle_speed_rpm")


def _ivester_force(
    calibration: IvesterSpindleLoadCalibration,
    load_V: float,
    u_load_V: float,
    idle_load_V: float,
    u_idle_load_V: float,
    speed_rpm: float,
    diameter_mm: float,
    u_diameter_mm: float,
) -> Converted:
    m = ivester_ratio_N_mm_per_V(rpm_to_rad_s(speed_rpm), calibration)
    net_V = load_V - idle_load_V
    force = m * net_V / diameter_mm
    u_net_V = math.hypot(u_load_V, u_idle_load_V)
    # Eq. 4, ΔF = F·sqrt((ΔD/D)² + (ΔL/L)² + (Δm/m)²), written as F·ΔL/L = m·ΔL/D so that
    # it holds at L = 0 too.
    u_force = math.sqrt(
        (force * u_diameter_mm / diameter_mm) ** 2
        + (m * u_net_V / diameter_mm) ** 2
        + (force * calibration.u_m_N_mm_per_V / m) ** 2
    )
    return Converted(force, u_force)


def ivester_force_N(
    load_V: float,
    u_load_V: float,
    spindle_speed_rpm: float,
    workpiece_diameter_mm: float,
    *,
    idle_load_V: float,
    u_idle_load_V: float = 0.0,
    u_workpiece_diameter_mm: float = 0.0,
    calibration: IvesterSpindleLoadCalibration = IVESTER_SPINDLE_LOAD,
) -> Converted:
    r"""Cutting force from the spindle load signal (Ivester & Heigel Eqs. 1-4).

    .. math::

        F = \frac{m(\phi)\,(L - L_\text{idle})}{D}, \qquad
        \Delta F = F \sqrt{\left(\frac{\Delta D}{D}\right)^2
            + \left(\frac{\Delta L}{L}\right)^2 + \left(\frac{\Delta m}{m}\right)^2}

    with ``L`` the net load and ``ΔL² = u_load² + u_idle²``. Eq. 4 is the first-order (GUM)
    law for Eq. 3, whose inputs all have exponent ±1, so the two agree; what Eq. 4 leaves out,
    and this function too, is the spindle speed's uncertainty (``m`` depends on it above
    70.2 rad/s) and any correlation of the load and idle-load readings.

    Parameters
    ----------
    load_V, u_load_V : float
        Spindle load signal while cutting and its standard uncertainty [V].
    spindle_speed_rpm : float
        Spindle speed [rpm]; ``φ = 2π n/60`` [rad/s] selects Eq. 1 or Eq. 2.
    workpiece_diameter_mm, u_workpiece_diameter_mm : float
        Working diameter ``D`` and its standard uncertainty [mm].
    idle_load_V, u_idle_load_V : float
        Idle load at that spindle speed, measured without cutting (see
        :func:`ivester_idle_load_V`), and its standard uncertainty [V].
    calibration : IvesterSpindleLoadCalibration
        Constants of Eqs. 1-2 and ``u_m`` (default: the paper's).

    Returns
    -------
    Converted
        Cutting force [N] and its standard uncertainty [N]. A load below the idle load gives
        a negative force (no cutting); :func:`to_force` refuses it.

    References
    ----------
    .. [1] Ivester & Heigel, Eqs. 1-4.
    .. [2] JCGM 100:2008 (GUM), Eq. 10.
    """
    return _ivester_force(
        calibration,
        fields.number(load_V, "load_V", minimum=0.0),
        fields.uncertainty(u_load_V, "u_load_V"),
        fields.number(idle_load_V, "idle_load_V", minimum=0.0),
        fields.uncertainty(u_idle_load_V, "u_idle_load_V"),
        fields.number(spindle_speed_rpm, "spindle_speed_rpm", positive=True),
        fields.number(workpiece_diameter_mm, "workpiece_diameter_mm", positive=True),
        fields.uncertainty(u_workpiece_diameter_mm, "u_workpiece_diameter_mm"),
    )


def ivester_spindle_torque_Nm(
    load_V: float,
    u_load_V: float,
    spindle_speed_rpm: float,
    *,
    idle_load_V: float,
    u_idle_load_V: float = 0.0,
    calibration: IvesterSpindleLoadCalibration = IVESTER_SPINDLE_LOAD,
) -> Converted:
    r"""Cutting torque from the spindle load: ``T = F·D/2 = m·L/2`` (Ivester & Heigel Eq. 3).

    .. math:: T\,[\text{N·m}] = \frac{m\,(L - L_\text{idle})}{2000}, \qquad
              \left(\frac{u_T}{T}\right)^2 = \left(\frac{u_L}{L}\right)^2
              + \left(\frac{u_m}{m}\right)^2

    The force is this torque over the radius: ``F = T / (D/2000 m)`` = Eq. 3.

    Parameters
    ----------
    load_V, u_load_V : float
        Spindle load while cutting and its standard uncertainty [V].
    spindle_speed_rpm : float
        Spindle speed [rpm].
    idle_load_V, u_idle_load_V : float
        Idle load at that speed and its standard uncertainty [V].
    calibration : IvesterSpindleLoadCalibration
        Constants of Eqs. 1-2.

    Returns
    -------
    Converted
        Torque [N·m] and its standard uncertainty [N·m].

    References
    ----------
    .. [1] Ivester & Heigel, Eq. 3 ("multiplying the measured cutting force by the working
       radius"), Eqs. 1-2 and 4.
    """
    m = ivester_ratio_N_mm_per_V(
        rpm_to_rad_s(fields.number(spindle_speed_rpm, "spindle_speed_rpm", positive=True)),
        calibration,
    )
    net_V = fields.number(load_V, "load_V", minimum=0.0) - fields.number(
        idle_load_V, "idle_load_V", minimum=0.0
    )
    u_net_V = math.hypot(
        fields.uncertainty(u_load_V, "u_load_V"), fields.uncertainty(u_idle_load_V, "u_idle_load_V")
    )
    torque = m * net_V / 2000.0
    u_torque = math.hypot(m * u_net_V / 2000.0, torque * calibration.u_m_N_mm_per_V / m)
    return Converted(torque, u_torque)


def ivester_load_V(
    force_N: float,
    spindle_speed_rpm: float,
    workpiece_diameter_mm: float,
    *,
    idle_load_V: float,
    calibration: IvesterSpindleLoadCalibration = IVESTER_SPINDLE_LOAD,
) -> float:
    """Spindle load a cutting force would show, Eq. 3 inverted: ``L = F·D/m + L_idle``.

    Parameters
    ----------
    force_N : float
        Cutting force [N], ``>= 0``.
    spindle_speed_rpm : float
        Spindle speed [rpm].
    workpiece_diameter_mm : float
        Working diameter [mm].
    idle_load_V : float
        Idle load at that speed [V].
    calibration : IvesterSpindleLoadCalibration
        Constants of Eqs. 1-2.

    Returns
    -------
    float
        Spindle load signal [V].

    References
    ----------
    .. [1] Ivester & Heigel, Eqs. 1-3.
    """
    force = fields.number(force_N, "force_N", minimum=0.0)
    speed = fields.number(spindle_speed_rpm, "spindle_speed_rpm", positive=True)
    diameter = fields.number(workpiece_diameter_mm, "workpiece_diameter_mm", positive=True)
    idle = fields.number(idle_load_V, "idle_load_V", minimum=0.0)
    return force * diameter / ivester_ratio_N_mm_per_V(rpm_to_rad_s(speed), calibration) + idle
