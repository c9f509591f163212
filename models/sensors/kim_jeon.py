"""Kim & Jeon (Precision Engineering 2011), §6: spindle current → cutting force.

The RMS of the three phase currents (§6) and a linear current → force calibration fitted or
taken from a published relation (§6.1.3, §6.2.3). Calibrations at several feed rates,
interpolated in between (§6.2.3, §7), are in :mod:`models.sensors.kim_jeon_feed`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from models import fields
from models.errors import InputError, ModelDomainError
from models.sensors.converted import Converted
from models.sensors.least_squares import least_squares, uncertainties_from_covariance


def kim_jeon_rms_current_A(
    phase_currents_A: Sequence[float], u_phase_currents_A: Sequence[float] | None = None
) -> Converted:
    r"""RMS of the three phase currents of an AC induction motor (Kim & Jeon §6).

    .. math:: I_\text{RMS} = \sqrt{\frac{I_U^2 + I_V^2 + I_W^2}{3}}, \qquad
              u_I^2 = \sum_p \left(\frac{I_p}{3 I_\text{RMS}} u_p\right)^2

    The paper prints ``I_RMS = sqrt((I_U² + I_V² + I_W²))/3``; the parentheses inside the
    root only make sense if ``/3`` was inside it, and only then is it a root *mean* square
    (for a balanced set it equals the per-phase RMS; the printed form is √3 smaller). A
    current → force calibration must be fitted with the same definition it is used with.

    Parameters
    ----------
    phase_currents_A : sequence of 3 float
        U-, V- and W-phase currents [A] (instantaneous, signed, or per-phase RMS values).
    u_phase_currents_A : sequence of 3 float, optional
        Their standard uncertainties [A], taken as independent (default: exact).

    Returns
    -------
    Converted
        ``I_RMS`` [A] and its standard uncertainty [A]. At ``I_RMS = 0`` the root is not
        differentiable; the uncertainty given there is ``sqrt(Σ u_p²/3)``, the RMS of the
        phase uncertainties.

    References
    ----------
    .. [1] Kim & Jeon, Precision Engineering 2011, §6 (first paragraph).
    """
    currents = fields.number_list(phase_currents_A, "phase_currents_A")
    if len(currents) != 3:
        raise InputError("phase_currents_A", phase_currents_A, "needs the 3 phase currents")
    u: tuple[float, ...] = (0.0, 0.0, 0.0)
    if u_phase_currents_A is not None:
        u = fields.number_list(u_phase_currents_A, "u_phase_currents_A", minimum=0.0)
        if len(u) != 3:
            raise InputError("u_phase_currents_A", u_phase_currents_A, "needs 3 uncertainties")
    rms = math.sqrt(sum(i * i for i in currents) / 3.0)
    if rms == 0.0:
        return Converted(0.0, math.sqrt(sum(x * x for x in u) / 3.0))
    u_rms = math.sqrt(sum((i * ui / (3.0 * rms)) ** 2 for i, ui in zip(currents, u, strict=True)))
    return Converted(rms, u_rms)


@dataclass(frozen=True)
class LinearCurrentCalibration:
    r"""A linear current → force calibration ``F = a + b·I`` with its parameters' covariance.

    Parameters
    ----------
    offset_N : float
        Offset ``a`` [N] (the force at zero current; negative when the motor draws current
        without cutting).
    slope_N_per_A : float
        Slope ``b`` [N/A], ``> 0``.
    u_offset_N, u_slope_N_per_A : float
        Standard uncertainties of ``a`` [N] and ``b`` [N/A].
    corr_offset_slope : float
        Correlation of ``a`` and ``b`` [-].
    residual_sd_N : float
        Residual standard deviation ``s`` of the calibration points about the line [N].
    n : int
        Number of calibration points (0: not known).
    feed_rate_mm_min : float or None
        Feed rate the calibration was made at [mm/min] (Kim & Jeon: the relation changes with
        it).
    spindle_speed_rpm : float or None
        Spindle speed the calibration was made at [rpm]; when set, :func:`to_force` refuses
        readings at speeds further than ``speed_tolerance_rel`` from it (Kim & Jeon §6.1.3:
        "the current-force relation needs to be reevaluated for different N_s").
    speed_tolerance_rel : float
        Relative tolerance on the spindle speed [-].
    source, reference, date, notes : str
        Provenance.
    """

    kind: ClassVar[str] = "linear_current"

    offset_N: float
    slope_N_per_A: float
    u_offset_N: float = 0.0
    u_slope_N_per_A: float = 0.0
    corr_offset_slope: float = 0.0
    residual_sd_N: float = 0.0
    n: int = 0
    feed_rate_mm_min: float | None = None
    spindle_speed_rpm: float | None = None
    speed_tolerance_rel: float = 0.05
    source: str = ""
    reference: str = ""
    date: str = ""
    notes: str = ""

    def __post_init__(self) -> None:
        fields.check_field(self, "offset_N")
        fields.check_field(self, "slope_N_per_A", positive=True)
        for name in ("u_offset_N", "u_slope_N_per_A", "residual_sd_N", "speed_tolerance_rel"):
            fields.check_field(self, name, minimum=0.0)
        fields.check_field(self, "corr_offset_slope", correlation=True)
        fields.count(self.n, "n")
        fields.check_field(self, "feed_rate_mm_min", positive=True, optional=True)
        fields.check_field(self, "spindle_speed_rpm", positive=True, optional=True)

    @property
    def covariance(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """Covariance matrix of ``(a, b)`` [[N², N²/A], [N²/A, N²/A²]]."""
        cov_ab = self.corr_offset_slope * self.u_offset_N * self.u_slope_N_per_A
        return ((self.u_offset_N**2, cov_ab), (cov_ab, self.u_slope_N_per_A**2))


def _fit_force_on_current(
    currents_A: Iterable[float], forces_N: Iterable[float]
) -> tuple[npt.NDArray[Any], list[float], npt.NDArray[Any], float, int]:
    """OLS of force on current for :func:`fit_linear_calibration`, its inputs checked first.

    Returns ``[a, b]``, their standard uncertainties, their correlation matrix, ``s`` and ``n``.
    """
    currents = np.asarray(fields.number_list(currents_A, "currents_A", minimum=0.0))
    forces = np.asarray(fields.number_list(forces_N, "forces_N", minimum=0.0))
    if currents.size != forces.size:
        raise InputError("forces_N", forces_N, f"needs one force per current ({currents.size})")
    if currents.size < 3:
        raise InputError("currents_A", currents_A, "needs at least 3 points")
    if float(np.ptp(currents)) == 0.0:
        raise InputError("currents_A", currents_A, "must not all be equal")
    beta, cov, s = least_squares(np.column_stack([np.ones_like(currents), currents]), forces)
    if beta[1] <= 0:
        raise ModelDomainError("forces_N", forces_N, "force must rise with current")
    u, corr = uncertainties_from_covariance(cov)
    return beta, u, corr, s, int(currents.size)


def fit_linear_calibration(
    currents_A: Iterable[float],
    forces_N: Iterable[float],
    *,
    source: str = "least-squares fit",
    reference: str = "",
    date: str = "",
    notes: str = "",
    feed_rate_mm_min: float | None = None,
    spindle_speed_rpm: float | None = None,
) -> LinearCurrentCalibration:
    r"""Fit ``F = a + b·I`` to paired (current, force) data by ordinary least squares.

    .. math:: \hat\beta = (X^\top X)^{-1} X^\top F, \qquad
              s^2 = \frac{\sum r_i^2}{n - 2}, \qquad
              \operatorname{cov}(\hat a, \hat b) = s^2 (X^\top X)^{-1}, \qquad X = [1, I]

    Kim & Jeon find the quasi-static current-force relation linear (§6.1.3, §6.2.3) and fit
    it as current on force, ``I = c + s·F``; this fits force on current, the direction the
    conversion is used in (the force is the dynamometer reference, the current the reading).

    Parameters
    ----------
    currents_A : iterable of float
        RMS spindle currents [A], ``>= 0``, not all equal.
    forces_N : iterable of float
        Dynamometer forces at the same instants [N], ``>= 0``.
    source, reference, date, notes : str
        Provenance stored on the calibration.
    feed_rate_mm_min, spindle_speed_rpm : float, optional
        Conditions of the calibration cuts [mm/min], [rpm].

    Returns
    -------
    LinearCurrentCalibration
        ``a``, ``b``, their standard errors and correlation, ``s`` and ``n`` (at least 3
        points, so that ``s`` is defined).

    References
    ----------
    .. [1] Kim & Jeon, §6.1.3 (Fig. 9) and §6.2.3.
    .. [2] GUM (JCGM 100:2008) Annex H.3 (calibration of a linear relation).
    """
    beta, u, corr, s, n = _fit_force_on_current(currents_A, forces_N)
    return LinearCurrentCalibration(
        offset_N=float(beta[0]),
        slope_N_per_A=float(beta[1]),
        u_offset_N=u[0],
        u_slope_N_per_A=u[1],
        corr_offset_slope=float(corr[0, 1]),
        residual_sd_N=s,
        n=n,
        feed_rate_mm_min=feed_rate_mm_min,
        spindle_speed_rpm=spindle_speed_rpm,
        source=source,
        reference=reference,
        date=date,
        notes=notes,
    )


def calibration_from_current_relation(
    slope_A_per_N: float,
    offset_A: float,
    *,
    feed_rate_mm_min: float | None = None,
    spindle_speed_rpm: float | None = None,
    source: str = "",
    reference: str = "",
) -> LinearCurrentCalibration:
    """A force calibration from a published current relation ``I = s·F + c`` (Kim & Jeon).

    ``F = (I − c)/s``, i.e. ``a = −c/s`` and ``b = 1/s``. The paper gives no uncertainties
    for its relations, so the calibration has none.

    Parameters
    ----------
    slope_A_per_N : float
        Sensitivity ``s`` [A/N], ``> 0``.
    offset_A : float
        Current at zero force ``c`` [A].
    feed_rate_mm_min, spindle_speed_rpm : float, optional
        Conditions of the relation [mm/min], [rpm].
    source, reference : str
        Provenance.

    Returns
    -------
    LinearCurrentCalibration
        The inverted relation.

    References
    ----------
    .. [1] Kim & Jeon, §6.2.3.
    """
    s = fields.number(slope_A_per_N, "slope_A_per_N", positive=True)
    c = fields.number(offset_A, "offset_A")
    return LinearCurrentCalibration(
        offset_N=-c / s,
        slope_N_per_A=1.0 / s,
        feed_rate_mm_min=feed_rate_mm_min,
        spindle_speed_rpm=spindle_speed_rpm,
        source=source,
        reference=reference,
    )


def _linear_force(
    cal: LinearCurrentCalibration, current_A: float, u_current_A: float, include_residual: bool
) -> tuple[float, float, float]:
    """Force, its variance from the current, and from the calibration (parameters + s²)."""
    force = cal.offset_N + cal.slope_N_per_A * current_A
    var_current = (cal.slope_N_per_A * u_current_A) ** 2
    (vaa, vab), (_, vbb) = cal.covariance
    var_cal = vaa + current_A**2 * vbb + 2.0 * current_A * vab
    if include_residual:
        var_cal += cal.residual_sd_N**2
    return force, var_current, max(var_cal, 0.0)


def linear_current_force_N(
    calibration: LinearCurrentCalibration,
    current_A: float,
    u_current_A: float = 0.0,
    *,
    include_residual: bool = True,
) -> Converted:
    r"""Cutting force from the spindle current by a linear calibration (Kim & Jeon §6.2.3).

    .. math:: F = a + b I, \qquad
              u_F^2 = (b\,u_I)^2 + u_a^2 + I^2 u_b^2 + 2 I\,u(a, b) + s^2

    Parameters
    ----------
    calibration : LinearCurrentCalibration
        ``a``, ``b``, their covariance and the residual ``s``.
    current_A : float
        RMS spindle current [A] (:func:`kim_jeon_rms_current_A`).
    u_current_A : float
        Its standard uncertainty [A].
    include_residual : bool
        Add ``s²``, the scatter of single readings about the line (a prediction, not a
        mean). It overlaps with ``u_current_A`` if that is the current's noise; it is the
        safe side.

    Returns
    -------
    Converted
        Force [N] and its standard uncertainty [N].

    References
    ----------
    .. [1] Kim & Jeon, §6.2.3; GUM (JCGM 100:2008) Eq. 13.
    """
    current = fields.number(current_A, "current_A", minimum=0.0)
    u_current = fields.uncertainty(u_current_A, "u_current_A")
    force, var_current, var_cal = _linear_force(calibration, current, u_current, include_residual)
    return Converted(force, math.sqrt(var_current + var_cal))
