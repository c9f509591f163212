r"""The robust reference current: the upper force band at the tool's strength.

Tai et al. set the reference current "based on the maximum cutting force that the tool could
bear" (§II.C) but measure only the current; with a current → force calibration (Kim & Jeon
§6.2.3) the largest current whose force, at the upper edge of its band, stays within the tool's
strength bounds the reference current from above.

References
----------
.. [1] Tai, Tsai & Li, IEEE Access (2023), §II.C and §II.F.
.. [2] Kim & Jeon, Precision Engineering (2011), §6.2.3; GUM (JCGM 100:2008) Eq. 13.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from models.errors import InputError, ModelDomainError
from models.fields import number
from models.sensors import LinearCurrentCalibration, linear_current_force_N

#: Coverage factor of the bands (GUM §6.2; Ivester & Heigel's ±2σ).
COVERAGE_K = 2.0


@dataclass(frozen=True)
class ForceLimit:
    """The tool's strength as a force, and the current → force calibration that reaches it.

    Parameters
    ----------
    strength_force_N : float
        Largest cutting force the tool may carry [N], ``> 0``.
    calibration : LinearCurrentCalibration
        Spindle current → force, ``F = a + b·I`` with its covariance and scatter (Kim & Jeon
        §6.2.3), made on this machine and spindle speed.
    u_current_A : float
        Standard uncertainty of a current reading [A], ``>= 0``.
    """

    strength_force_N: float
    calibration: LinearCurrentCalibration
    u_current_A: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(
            self,
            "strength_force_N",
            number(self.strength_force_N, "strength_force_N", positive=True),
        )
        object.__setattr__(self, "u_current_A", number(self.u_current_A, "u_current_A", minimum=0))
        if not isinstance(self.calibration, LinearCurrentCalibration):
            raise InputError("calibration", self.calibration, "must be a LinearCurrentCalibration")


def _band_root_A(strength: ForceLimit, k: float, alpha: float) -> float:
    """The smaller root of the quadratic of :func:`strength_current_A`, polished by Newton.

    ``alpha = b² − k²u_b² > 0``: the band rises with the current, so the root is the current
    where it meets the strength.
    """
    cal = strength.calibration
    a, b = cal.offset_N, cal.slope_N_per_A
    (var_a, cov_ab), (_, var_b) = cal.covariance
    c = strength.strength_force_N - a
    c0 = var_a + cal.residual_sd_N**2 + (b * strength.u_current_A) ** 2
    beta = b * c + k * k * cov_ab
    gamma = c * c - k * k * c0
    denominator = beta + math.sqrt(max(beta * beta - alpha * gamma, 0.0))
    current = gamma / denominator if denominator > 0 else 0.0
    for _ in range(3):  # Newton on a + b·I + k·u_F(I) − F_s: the root loses digits to rounding
        u_f = math.sqrt(max(c0 + 2.0 * current * cov_ab + current * current * var_b, 0.0))
        excess = a + b * current + k * u_f - strength.strength_force_N
        slope = b + (k * (current * var_b + cov_ab) / u_f if u_f > 0 else 0.0)
        current = max(current - excess / slope, 0.0)
    return current


def strength_current_A(strength: ForceLimit, *, coverage_k: float = COVERAGE_K) -> float:
    r"""Largest spindle current whose upper force band stays at or under the tool's strength.

    With ``F = a + b·I`` and its single-reading variance
    ``u_F² = u_a² + 2I·u(a,b) + I²u_b² + s² + (b·u_I)²`` (Kim & Jeon §6.2.3, GUM Eq. 13),
    ``F + k·u_F = F_s`` is the smaller root of the quadratic

    .. math:: (b^2 - k^2 u_b^2) I^2 - 2 (b c + k^2 u_{ab}) I + c^2 - k^2 C_0 = 0,
              \qquad c = F_s - a, \quad C_0 = u_a^2 + s^2 + (b u_I)^2

    (the root with ``c − b·I >= 0``; ``F + k·u_F`` rises with ``I`` when ``b > k·u_b``).

    Parameters
    ----------
    strength : ForceLimit
        Strength [N], calibration and current uncertainty.
    coverage_k : float
        Coverage factor of the force band [-].

    Returns
    -------
    float
        The current [A].

    Raises
    ------
    InputError
        The slope is not known to better than ``k·u_b``, or the force band exceeds the
        strength already at zero current.
    """
    k = number(coverage_k, "coverage_k", positive=True)
    cal = strength.calibration
    b = cal.slope_N_per_A
    var_b = cal.covariance[1][1]
    alpha = b * b - k * k * var_b
    if alpha <= 0:
        raise InputError(
            "calibration.u_slope_N_per_A",
            cal.u_slope_N_per_A,
            f"the slope {b:.6g} N/A is not known to better than {k:g}·u: the force band does "
            "not rise with the current",
        )
    at_zero = linear_current_force_N(cal, 0.0, strength.u_current_A)
    if at_zero.value + k * at_zero.uncertainty > strength.strength_force_N:
        raise InputError(
            "strength_force_N",
            strength.strength_force_N,
            f"below the upper force band at zero current, "
            f"{at_zero.value + k * at_zero.uncertainty:.4g} N",
        )
    current = _band_root_A(strength, k, alpha)
    check = linear_current_force_N(cal, current, strength.u_current_A)
    excess = check.value + k * check.uncertainty - strength.strength_force_N
    if excess > 1e-9 * strength.strength_force_N:  # re-check with the model (STYLE.md)
        raise ModelDomainError("strength_force_N", strength.strength_force_N, "no current found")
    return current
