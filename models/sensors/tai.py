"""Tai, Tsai & Li (IEEE Access 2023): spindle current vs feed rate and flank wear, Eqs. 13-15.

Eq. 14, ``I = A + B·f + k1·VB`` (Eq. 13 at ``VB = 0``), fitted to constant-feed tests, its
inversion for the feed rate (Eq. 15) and the reference current of §III.A.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from models import fields
from models.errors import InputError, ModelDomainError
from models.sensors.converted import Converted
from models.sensors.least_squares import (
    covariance_matrix,
    least_squares,
    uncertainties_from_covariance,
)

_TAI_PARAMS = ("idle_current_A", "slope_A_per_mm_min", "wear_coefficient_A_per_mm")
_TAI_CORR = {(0, 1): "corr_idle_slope", (0, 2): "corr_idle_wear", (1, 2): "corr_slope_wear"}


@dataclass(frozen=True)
class TaiCurrentFeedCalibration:
    r"""Spindle current vs feed rate and flank wear, ``I = A + B·f + k1·VB`` (Tai et al. Eq. 14).

    Parameters
    ----------
    idle_current_A : float
        ``A``, "the idle spindle current when the feedrate is zero" [A].
    slope_A_per_mm_min : float
        ``B``, current per feed rate [A/(mm/min)], ``> 0``.
    wear_coefficient_A_per_mm : float
        ``k1``, the flank wear coefficient [A/mm] (the paper gives VB in µm).
    u_idle_current_A, u_slope_A_per_mm_min, u_wear_coefficient_A_per_mm : float
        Standard uncertainties of ``A``, ``B``, ``k1``.
    corr_idle_slope, corr_idle_wear, corr_slope_wear : float
        Their correlations [-].
    residual_sd_A : float
        Residual standard deviation of the test data about the plane [A].
    n : int
        Number of test points (0: not known).
    source, reference, date, notes : str
        Provenance.
    """

    kind: ClassVar[str] = "tai_current_feed"

    idle_current_A: float
    slope_A_per_mm_min: float
    wear_coefficient_A_per_mm: float = 0.0
    u_idle_current_A: float = 0.0
    u_slope_A_per_mm_min: float = 0.0
    u_wear_coefficient_A_per_mm: float = 0.0
    corr_idle_slope: float = 0.0
    corr_idle_wear: float = 0.0
    corr_slope_wear: float = 0.0
    residual_sd_A: float = 0.0
    n: int = 0
    source: str = ""
    reference: str = ""
    date: str = ""
    notes: str = ""

    def __post_init__(self) -> None:
        fields.check_field(self, "idle_current_A")
        fields.check_field(self, "slope_A_per_mm_min", positive=True)
        fields.check_field(self, "wear_coefficient_A_per_mm")
        for name in (*(f"u_{p}" for p in _TAI_PARAMS), "residual_sd_A"):
            fields.check_field(self, name, minimum=0.0)
        for name in _TAI_CORR.values():
            fields.check_field(self, name, correlation=True)
        fields.count(self.n, "n")
        corr = np.eye(3)
        for (i, j), name in _TAI_CORR.items():
            corr[i, j] = corr[j, i] = getattr(self, name)
        if float(np.linalg.eigvalsh(corr).min()) < -1e-9:
            names = ", ".join(_TAI_CORR.values())
            raise InputError(
                "corr_idle_slope",
                self.corr_idle_slope,
                f"with the other correlations ({names}) makes no valid covariance matrix",
            )

    @property
    def covariance(self) -> tuple[tuple[float, ...], ...]:
        """Covariance matrix of ``(A, B, k1)`` (units: A, A/(mm/min), A/mm)."""
        u = [getattr(self, f"u_{name}") for name in _TAI_PARAMS]
        return covariance_matrix(u, {ij: getattr(self, name) for ij, name in _TAI_CORR.items()})


def _checked_tests(
    feed_rates_mm_min: Iterable[float],
    flank_wears_mm: Iterable[float],
    currents_A: Iterable[float],
) -> tuple[npt.NDArray[Any], npt.NDArray[Any]]:
    """The design matrix ``[1, f, VB]`` and the currents of checked test data (Tai Eq. 14).

    Refused: unequal lengths, fewer than 4 points, and feed rates and wears that do not vary
    independently (``B`` and ``k1`` would not be identified).
    """
    feeds = np.asarray(fields.number_list(feed_rates_mm_min, "feed_rates_mm_min", positive=True))
    wears = np.asarray(fields.number_list(flank_wears_mm, "flank_wears_mm", minimum=0.0))
    currents = np.asarray(fields.number_list(currents_A, "currents_A", minimum=0.0))
    if wears.size != feeds.size:
        raise InputError("flank_wears_mm", flank_wears_mm, f"needs {feeds.size} values")
    if currents.size != feeds.size:
        raise InputError("currents_A", currents_A, f"needs {feeds.size} values")
    if feeds.size < 4:
        raise InputError("feed_rates_mm_min", feed_rates_mm_min, "needs at least 4 points")
    design = np.column_stack([np.ones_like(feeds), feeds, wears])
    if np.linalg.matrix_rank(design) < 3:
        raise InputError(
            "flank_wears_mm",
            flank_wears_mm,
            "feed rates and flank wears must vary independently to identify B and k1",
        )
    return design, currents


def fit_tai_calibration(
    feed_rates_mm_min: Iterable[float],
    flank_wears_mm: Iterable[float],
    currents_A: Iterable[float],
    *,
    source: str = "least-squares fit",
    reference: str = "",
    date: str = "",
    notes: str = "",
) -> TaiCurrentFeedCalibration:
    r"""Fit ``I = A + B·f + k1·VB`` to constant-feed test data (Tai et al. Eqs. 13-14).

    Ordinary least squares with ``X = [1, f, VB]``; covariance ``s²(XᵀX)⁻¹`` with
    ``s² = Σr²/(n − 3)``. The data need at least two feed rates and, to identify ``k1``,
    worn as well as sharp tools (the paper's Figures 4-8: sharp-tool tests for ``A, B``,
    wear tests at constant feed for ``k1``).

    Parameters
    ----------
    feed_rates_mm_min : iterable of float
        Feed rate of each test point [mm/min], ``> 0``.
    flank_wears_mm : iterable of float
        Flank wear VB at each point [mm], ``>= 0``.
    currents_A : iterable of float
        Spindle current at each point [A], ``>= 0``.
    source, reference, date, notes : str
        Provenance.

    Returns
    -------
    TaiCurrentFeedCalibration
        ``A, B, k1`` with standard errors, correlations, ``s`` and ``n`` (at least 4 points).

    References
    ----------
    .. [1] Tai, Tsai & Li, Eqs. 13-14 and §III.A.
    """
    design, currents = _checked_tests(feed_rates_mm_min, flank_wears_mm, currents_A)
    beta, cov, s = least_squares(design, currents)
    if beta[1] <= 0:
        raise ModelDomainError("currents_A", currents_A, "current must rise with feed rate")
    u, corr = uncertainties_from_covariance(cov)
    return TaiCurrentFeedCalibration(
        idle_current_A=float(beta[0]),
        slope_A_per_mm_min=float(beta[1]),
        wear_coefficient_A_per_mm=float(beta[2]),
        u_idle_current_A=u[0],
        u_slope_A_per_mm_min=u[1],
        u_wear_coefficient_A_per_mm=u[2],
        corr_idle_slope=float(corr[0, 1]),
        corr_idle_wear=float(corr[0, 2]),
        corr_slope_wear=float(corr[1, 2]),
        residual_sd_A=s,
        n=int(currents.size),
        source=source,
        reference=reference,
        date=date,
        notes=notes,
    )


def tai_spindle_current_A(
    calibration: TaiCurrentFeedCalibration,
    feed_rate_mm_min: float,
    flank_wear_mm: float = 0.0,
    *,
    u_feed_rate_mm_min: float = 0.0,
    u_flank_wear_mm: float = 0.0,
) -> Converted:
    r"""Spindle current at a feed rate and flank wear (Tai et al. Eq. 14; Eq. 13 at VB = 0).

    .. math:: I_M = A + B f_m + k_1 V_B, \qquad
              u_I^2 = g \Sigma g^\top + (B u_f)^2 + (k_1 u_{VB})^2, \quad g = (1, f_m, V_B)

    Parameters
    ----------
    calibration : TaiCurrentFeedCalibration
        ``A, B, k1`` and their covariance ``Σ``.
    feed_rate_mm_min : float
        Feed rate ``f_m`` [mm/min].
    flank_wear_mm : float
        Flank wear ``V_B`` [mm].
    u_feed_rate_mm_min, u_flank_wear_mm : float
        Standard uncertainties of ``f_m`` and ``V_B``.

    Returns
    -------
    Converted
        Spindle current [A] and its standard uncertainty [A] (of the mean current; the
        residual scatter is not added).

    References
    ----------
    .. [1] Tai, Tsai & Li, Eqs. 13 and 14.
    """
    feed = fields.number(feed_rate_mm_min, "feed_rate_mm_min", minimum=0.0)
    wear = fields.number(flank_wear_mm, "flank_wear_mm", minimum=0.0)
    u_feed = fields.uncertainty(u_feed_rate_mm_min, "u_feed_rate_mm_min")
    u_wear = fields.uncertainty(u_flank_wear_mm, "u_flank_wear_mm")
    cal = calibration
    current = (
        cal.idle_current_A + cal.slope_A_per_mm_min * feed + cal.wear_coefficient_A_per_mm * wear
    )
    g = np.array([1.0, feed, wear])
    var = float(g @ np.asarray(cal.covariance) @ g)
    var += (cal.slope_A_per_mm_min * u_feed) ** 2 + (cal.wear_coefficient_A_per_mm * u_wear) ** 2
    return Converted(current, math.sqrt(max(var, 0.0)))


def tai_feed_rate_mm_min(
    calibration: TaiCurrentFeedCalibration,
    current_A: float,
    flank_wear_mm: float = 0.0,
    *,
    u_current_A: float = 0.0,
    u_flank_wear_mm: float = 0.0,
) -> Converted:
    r"""Feed rate that gives a spindle current at a flank wear (Tai et al. Eq. 15).

    .. math:: f_m = \frac{I_M - A}{B} - \frac{k_1}{B} V_B

    At the reference current and ``V_B = 0`` this is the upper feed-rate limit; at the
    largest allowed wear, the lower limit (Tai et al. §II, after Eq. 15). First order (GUM
    Eq. 13), with ``Σ`` the covariance of ``(A, B, k1)``:

    .. math:: u_f^2 = g \Sigma g^\top + \left(\frac{u_I}{B}\right)^2
              + \left(\frac{k_1 u_{VB}}{B}\right)^2, \qquad
              g = -\frac{1}{B}\,(1,\ f_m,\ V_B)

    Parameters
    ----------
    calibration : TaiCurrentFeedCalibration
        ``A, B, k1`` and their covariance.
    current_A : float
        Spindle (reference) current ``I_M`` [A].
    flank_wear_mm : float
        Flank wear ``V_B`` [mm].
    u_current_A, u_flank_wear_mm : float
        Standard uncertainties of ``I_M`` [A] and ``V_B`` [mm].

    Returns
    -------
    Converted
        Feed rate [mm/min] and its standard uncertainty [mm/min]; refused when negative
        (the current is below what the wear alone draws).

    References
    ----------
    .. [1] Tai, Tsai & Li, Eq. 15.
    """
    current = fields.number(current_A, "current_A", minimum=0.0)
    wear = fields.number(flank_wear_mm, "flank_wear_mm", minimum=0.0)
    u_current = fields.uncertainty(u_current_A, "u_current_A")
    u_wear = fields.uncertainty(u_flank_wear_mm, "u_flank_wear_mm")
    cal = calibration
    b = cal.slope_A_per_mm_min
    feed = (current - cal.idle_current_A - cal.wear_coefficient_A_per_mm * wear) / b
    if feed < -1e-9:  # below rounding of mm/min
        raise ModelDomainError(
            "current_A",
            current_A,
            f"below the current at zero feed rate ({current - b * feed:.6g} A at this wear)",
        )
    feed = max(feed, 0.0)
    g = -np.array([1.0, feed, wear]) / b
    var = float(g @ np.asarray(cal.covariance) @ g)
    var += (u_current / b) ** 2 + (cal.wear_coefficient_A_per_mm * u_wear / b) ** 2
    return Converted(feed, math.sqrt(max(var, 0.0)))


def tai_reference_current_A(max_current_A: float, factor: float = 0.85) -> float:
    """Spindle reference current for constant-load milling (Tai et al. §III.A).

    The paper multiplies the largest current the worn tool withstood, 0.28 A, by 0.85 and
    rounds 0.238 A to 0.24 A (it also calls this "a safety factor of 1.17"; 1/1.17 = 0.855).

    Parameters
    ----------
    max_current_A : float
        Largest spindle current the tool withstood in constant-feed wear tests [A].
    factor : float
        Fraction of it to use [-], in (0, 1].

    Returns
    -------
    float
        Reference current [A].
    """
    current = fields.number(max_current_A, "max_current_A", positive=True)
    k = fields.number(factor, "factor", positive=True)
    if k > 1:
        raise InputError("factor", factor, "must be at most 1")
    return current * k
