"""The virtual mill's plant: cutting process, spindle current, sensor, wear growth, workpiece.

Two processes give the true cutting force and spindle current at a feed rate, depth, spindle
speed and flank wear:

- :class:`ForceCurrentMill`: a force model (Kim & Jeon Eq. 1 or a power law) and a linear
  spindle current ``I = I_idle + s·F + k1·VB`` (Kim & Jeon §6.2.3 for ``I_idle`` and ``s``,
  Tai et al. Eq. 14 for the wear term);
- :class:`TaiMill`: Tai et al.'s current plane ``I = A + B·f + k1·VB`` (Eq. 14) of their end
  milling; it models no force.

:class:`CurrentSensor` adds the sensor's lag and noise; :class:`WearLaw` grows the flank wear
with the removed volume; :class:`StepWorkpiece` is a depth profile along the path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

from models import fields
from models.errors import InputError
from models.milling_force import ForceModel
from models.sensors import (
    LinearCurrentCalibration,
    TaiCurrentFeedCalibration,
    calibration_from_current_relation,
    tai_spindle_current_A,
)


class CutProcess(Protocol):
    """True force and spindle current of a cut."""

    def force_N(
        self, feed_rate_mm_min: float, depth_mm: float, spindle_rpm: float, flank_wear_mm: float
    ) -> float:
        """Cutting force [N] (NaN where the process does not model it)."""
        ...

    def current_A(
        self, feed_rate_mm_min: float, depth_mm: float, spindle_rpm: float, flank_wear_mm: float
    ) -> float:
        """Spindle current [A]."""
        ...

    def force_calibration(self) -> LinearCurrentCalibration | None:
        """The current → force calibration a force-controlled loop reads with, if any."""
        ...


@dataclass(frozen=True)
class ForceCurrentMill:
    r"""A force model read through a linear spindle current, with wear.

    .. math:: F = F_\text{model}(f, d, N_s) + k_F V_B, \qquad
              I = I_\text{idle} + s F + k_1 V_B \quad (d > 0,\ f > 0)

    Not cutting, ``F = 0`` and ``I = I_idle``.

    Parameters
    ----------
    force_model : ForceModel
        E.g. :class:`~models.milling_force.KimJeonForceModel`.
    idle_current_A : float
        Current at zero force [A]. Default 3.206 A: Kim & Jeon §6.2.3, the ACE-V30 spindle,
        ``I = 5.762e-3 F_max + 3.206`` at 150 mpm (the relation nearest the feeds of Case 1;
        it was measured at 4500 rpm, the paper gives none at Case 1's 1500 rpm).
    slope_A_per_N : float
        ``s`` [A/N], ``> 0``; default 5.762e-3 A/N (same source).
    wear_force_N_per_mm : float
        ``k_F``, force added per mm of flank wear [N/mm] (default 0).
    wear_current_A_per_mm : float
        ``k_1``, current added per mm of flank wear [A/mm] (Tai et al. Eq. 14; default 0).
    """

    force_model: ForceModel
    idle_current_A: float = 3.206
    slope_A_per_N: float = 5.762e-3
    wear_force_N_per_mm: float = 0.0
    wear_current_A_per_mm: float = 0.0

    def __post_init__(self) -> None:
        fields.check_fields(
            self,
            positives=("slope_A_per_N",),
            non_negatives=("idle_current_A", "wear_force_N_per_mm", "wear_current_A_per_mm"),
        )

    def force_N(
        self, feed_rate_mm_min: float, depth_mm: float, spindle_rpm: float, flank_wear_mm: float
    ) -> float:
        """Cutting force [N]."""
        force = self.force_model.force_N(feed_rate_mm_min, depth_mm, spindle_rpm)
        if force <= 0.0:
            return 0.0
        return force + self.wear_force_N_per_mm * flank_wear_mm

    def current_A(
        self, feed_rate_mm_min: float, depth_mm: float, spindle_rpm: float, flank_wear_mm: float
    ) -> float:
        """Spindle current [A]."""
        force = self.force_N(feed_rate_mm_min, depth_mm, spindle_rpm, flank_wear_mm)
        if force <= 0.0:
            return self.idle_current_A
        wear = self.wear_current_A_per_mm * flank_wear_mm
        return self.idle_current_A + self.slope_A_per_N * force + wear

    def force_calibration(self) -> LinearCurrentCalibration:
        """``F = (I − I_idle)/s`` (:func:`models.sensors.calibration_from_current_relation`)."""
        return calibration_from_current_relation(
            self.slope_A_per_N,
            self.idle_current_A,
            source="virtual mill current relation",
            reference="Kim & Jeon §6.2.3",
        )


@dataclass(frozen=True)
class TaiMill:
    r"""Tai et al.'s end-milling current plane, scaled with the axial depth.

    .. math:: I = A + B f \frac{d}{d_0} + k_1 V_B \quad (d > 0), \qquad I = A \quad (d = 0)

    Tai et al. Eq. 14 holds at their fixed depth ``d_0``; Eq. 11 makes the cutting part of
    the current proportional to the axial depth, which scales it at other depths.

    Parameters
    ----------
    calibration : TaiCurrentFeedCalibration
        ``A, B, k1`` (:func:`models.sensors.tai_spindle_current_A`).
    nominal_depth_mm : float
        ``d_0`` [mm] (Tai et al. §II.E: axial depth 200 µm).
    """

    calibration: TaiCurrentFeedCalibration
    nominal_depth_mm: float = 0.2

    def __post_init__(self) -> None:
        fields.check_fields(self, positives=("nominal_depth_mm",))

    def force_N(
        self, feed_rate_mm_min: float, depth_mm: float, spindle_rpm: float, flank_wear_mm: float
    ) -> float:
        """Not modelled: NaN."""
        return math.nan

    def current_A(
        self, feed_rate_mm_min: float, depth_mm: float, spindle_rpm: float, flank_wear_mm: float
    ) -> float:
        """Spindle current [A] (Tai et al. Eq. 14)."""
        if depth_mm <= 0.0 or feed_rate_mm_min <= 0.0:
            return self.calibration.idle_current_A
        feed = feed_rate_mm_min * depth_mm / self.nominal_depth_mm
        return tai_spindle_current_A(self.calibration, feed, flank_wear_mm).value

    def force_calibration(self) -> None:
        """No force is modelled, so none."""
        return None


@dataclass(frozen=True)
class CurrentSensor:
    """Spindle current as the controller samples it: a first-order lag plus white noise.

    Parameters
    ----------
    noise_sd_A : float
        Standard deviation of the sampled noise [A], ``>= 0``.
    bandwidth_Hz : float
        −3 dB bandwidth of the lag [Hz], ``> 0``; ``math.inf`` for none. Kim & Jeon §6.2:
        the spindle-motor current is a force sensor of bandwidth below 5 Hz (belt and
        gears); the RMS conversion per revolution (§6) acts as a further averaging.
    """

    noise_sd_A: float = 0.0
    bandwidth_Hz: float = math.inf

    def __post_init__(self) -> None:
        object.__setattr__(self, "noise_sd_A", fields.at_least(self.noise_sd_A, "noise_sd_A"))
        if self.bandwidth_Hz != math.inf:
            object.__setattr__(
                self, "bandwidth_Hz", fields.positive(self.bandwidth_Hz, "bandwidth_Hz")
            )

    def smoothing(self, dt_s: float) -> float:
        """Weight of the new value in the discrete lag, ``1 − exp(−2π B dt)`` [-]."""
        if self.bandwidth_Hz == math.inf:
            return 1.0
        return -math.expm1(-2.0 * math.pi * self.bandwidth_Hz * dt_s)


@dataclass(frozen=True)
class WearLaw:
    r"""Flank wear growing in proportion to the removed volume.

    .. math:: \frac{dV_B}{dV} = r, \qquad dV = d\,a_e\,dx

    The simplest law that makes wear depend on what was cut, not on time alone; Tai et al.'s
    constant-load edges ran 2250 mm at ``a_p·a_e = 0.2 × 1.4 mm²`` to an average 197.26 µm
    (§III.D, Table 1), which gives ``r = 0.19726/(2250·0.28) = 3.131e-4 mm/mm³``.

    Parameters
    ----------
    rate_mm_per_mm3 : float
        ``r``, flank wear per removed volume [mm/mm³], ``>= 0``.
    """

    rate_mm_per_mm3: float = 0.0

    def __post_init__(self) -> None:
        fields.check_fields(self, non_negatives=("rate_mm_per_mm3",))


@dataclass(frozen=True)
class StepWorkpiece:
    """A workpiece whose axial depth of cut steps along the path.

    Parameters
    ----------
    segments : tuple of (length_mm, depth_mm)
        Consecutive stretches of the path [mm] and their depth of cut [mm], lengths ``> 0``,
        depths ``>= 0``.
    """

    segments: tuple[tuple[float, float], ...]

    def __post_init__(self) -> None:
        segments = tuple(self.segments)
        if not segments:
            raise InputError("segments", self.segments, "needs at least one segment")
        checked = []
        for i, segment in enumerate(segments):
            if not isinstance(segment, tuple | list) or len(segment) != 2:
                raise InputError(f"segments[{i}]", segment, "must be (length_mm, depth_mm)")
            checked.append(
                (
                    fields.positive(segment[0], f"segments[{i}].length_mm"),
                    fields.at_least(segment[1], f"segments[{i}].depth_mm"),
                )
            )
        object.__setattr__(self, "segments", tuple(checked))

    @property
    def length_mm(self) -> float:
        """Total path length [mm]."""
        return sum(length for length, _ in self.segments)

    @property
    def boundaries_mm(self) -> tuple[float, ...]:
        """Path position of each segment's end [mm]."""
        ends, total = [], 0.0
        for length, _ in self.segments:
            total += length
            ends.append(total)
        return tuple(ends)

    def segment_index(self, position_mm: float) -> int:
        """Index of the segment under ``position_mm``; the last one past the end."""
        for i, end in enumerate(self.boundaries_mm):
            if position_mm < end:
                return i
        return len(self.segments) - 1

    def depth_mm(self, position_mm: float) -> float:
        """Depth of cut at a path position [mm]; 0 before the start and after the end."""
        if position_mm < 0.0 or position_mm >= self.length_mm:
            return 0.0
        return self.segments[self.segment_index(position_mm)][1]
