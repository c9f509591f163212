r"""Shared pieces of the sensor conversions: the :class:`Converted` pair and checked numbers.

Checked numbers name the field they came from in errors; calibration dataclasses store them as
plain floats. The least-squares and covariance helpers serve the fits of Kim & Jeon (§6.2.3)
and Tai, Tsai & Li (Eqs. 13-14): the OLS covariance is :math:`s^2 (X^\top X)^{-1}` (GUM,
JCGM 100:2008, Annex H.3), and correlations turn into covariances for first-order
propagation (GUM Eq. 13).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from models import fields
from models.errors import InputError


@dataclass(frozen=True)
class Converted:
    """A converted value and its uncertainty (same unit; standard or expanded as the inputs).

    Unpacks as a pair: ``force_N, u_force_N = to_force(...)``.
    """

    value: float
    uncertainty: float

    def __iter__(self) -> Iterator[float]:
        """Yield ``value`` then ``uncertainty``."""
        yield self.value
        yield self.uncertainty


def _number(
    value: object, path: str, *, positive: bool = False, minimum: float | None = None
) -> float:
    """:func:`models.fields.number` that also takes numpy scalars (not bools)."""
    if isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_):
        return fields.number(float(value), path, positive=positive, minimum=minimum)
    return fields.number(value, path, positive=positive, minimum=minimum)


def _check_field(
    obj: object,
    name: str,
    *,
    positive: bool = False,
    minimum: float | None = None,
    correlation: bool = False,
) -> None:
    """Check a numeric field of a frozen dataclass and store it as a plain float."""
    value = getattr(obj, name)
    if value is None and name in _OPTIONAL_FIELDS:
        return
    number = _number(value, name, positive=positive, minimum=minimum)
    if correlation and not -1.0 <= number <= 1.0:
        raise InputError(name, value, "must be a correlation coefficient in [-1, 1]")
    object.__setattr__(obj, name, number)


def _check_count(n: object) -> None:
    if isinstance(n, bool) or not isinstance(n, int) or n < 0:
        raise InputError("n", n, "must be a whole number >= 0")


_OPTIONAL_FIELDS = ("feed_rate_mm_min", "spindle_speed_rpm")


def _uncertainty(value: object, path: str) -> float:
    """A finite uncertainty ``>= 0``."""
    return _number(value, path, minimum=0.0)


def _numbers(
    value: object, path: str, *, minimum: float | None = None, positive: bool = False
) -> tuple[float, ...]:
    """A list of finite numbers; errors name ``path[i]``."""
    if isinstance(value, str | bytes | Mapping) or not isinstance(value, Iterable):
        raise InputError(path, value, "must be a list of numbers")
    return tuple(
        _number(v, f"{path}[{i}]", minimum=minimum, positive=positive) for i, v in enumerate(value)
    )


def _covariance(
    u: Sequence[float], corr: Mapping[tuple[int, int], float]
) -> tuple[tuple[float, ...], ...]:
    """Covariance matrix from standard uncertainties and pairwise correlations."""
    cov = np.diag(np.square(np.asarray(u, dtype=float)))
    for (i, j), r in corr.items():
        cov[i, j] = cov[j, i] = r * u[i] * u[j]
    return tuple(tuple(float(x) for x in row) for row in cov)


def _uncertainties_from_covariance(cov: npt.NDArray[Any]) -> tuple[list[float], npt.NDArray[Any]]:
    """Standard uncertainties and correlation matrix of a covariance matrix."""
    u = [math.sqrt(max(float(cov[i, i]), 0.0)) for i in range(cov.shape[0])]
    corr = np.eye(cov.shape[0])
    for i in range(cov.shape[0]):
        for j in range(i + 1, cov.shape[0]):
            if u[i] > 0 and u[j] > 0:
                r = float(cov[i, j]) / (u[i] * u[j])
                corr[i, j] = corr[j, i] = min(1.0, max(-1.0, r))
    return u, corr


def _least_squares(
    design: npt.NDArray[Any], y: npt.NDArray[Any]
) -> tuple[npt.NDArray[Any], npt.NDArray[Any], float]:
    """OLS estimate, its covariance ``s²(XᵀX)⁻¹`` and residual standard deviation ``s``."""
    beta, _, _, _ = np.linalg.lstsq(design, y, rcond=None)
    residuals = y - design @ beta
    dof = design.shape[0] - design.shape[1]
    s = math.sqrt(float(residuals @ residuals) / dof)
    cov = s**2 * np.linalg.inv(design.T @ design)
    return beta, cov, s
