r"""Least squares and covariances for the sensor calibration fits.

They serve the fits of Kim & Jeon (§6.2.3) and Tai, Tsai & Li (Eqs. 13-14): the OLS covariance
is :math:`s^2 (X^\top X)^{-1}` (GUM, JCGM 100:2008, Annex H.3), and correlations turn into
covariances for first-order propagation (GUM Eq. 13).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt


def covariance_matrix(
    u: Sequence[float], corr: Mapping[tuple[int, int], float]
) -> tuple[tuple[float, ...], ...]:
    """Covariance matrix from standard uncertainties and pairwise correlations."""
    cov = np.diag(np.square(np.asarray(u, dtype=float)))
    for (i, j), r in corr.items():
        cov[i, j] = cov[j, i] = r * u[i] * u[j]
    return tuple(tuple(float(x) for x in row) for row in cov)


def uncertainties_from_covariance(cov: npt.NDArray[Any]) -> tuple[list[float], npt.NDArray[Any]]:
    """Standard uncertainties and correlation matrix of a covariance matrix."""
    u = [math.sqrt(max(float(cov[i, i]), 0.0)) for i in range(cov.shape[0])]
    corr = np.eye(cov.shape[0])
    for i in range(cov.shape[0]):
        for j in range(i + 1, cov.shape[0]):
            if u[i] > 0 and u[j] > 0:
                r = float(cov[i, j]) / (u[i] * u[j])
                corr[i, j] = corr[j, i] = min(1.0, max(-1.0, r))
    return u, corr


def least_squares(
    design: npt.NDArray[Any], y: npt.NDArray[Any]
) -> tuple[npt.NDArray[Any], npt.NDArray[Any], float]:
    """OLS estimate, its covariance ``s²(XᵀX)⁻¹`` and residual standard deviation ``s``."""
    beta, _, _, _ = np.linalg.lstsq(design, y, rcond=None)
    residuals = y - design @ beta
    dof = design.shape[0] - design.shape[1]
    s = math.sqrt(float(residuals @ residuals) / dof)
    cov = s**2 * np.linalg.inv(design.T @ design)
    return beta, cov, s
