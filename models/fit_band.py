r"""The uncertainty band ``±ΔK`` of a fitted power law, and the share of points it covers.

Used by :func:`models.fit.fit_power_law`. Every point :math:`j` implies its own coefficient
:math:`K_j = Y_j / \prod_i x_{ij}^{e_i}` (fitted and fixed exponents), and
:math:`K_j / K = \exp(r_j)`. The band ``ΔK`` is one of:

``"range"`` (Ivester & Heigel)
    The smallest ``ΔK`` for which every point lies inside ``(K ± ΔK) · Π x_i^e_i``:

    .. math::

        \Delta K = \max_j |K_j - K| = \max_j \frac{|Y_j - \hat Y_j|}{\prod_i x_{ij}^{e_i}}
                 = K \max_j |e^{r_j} - 1|

``"2s"`` (expanded uncertainty, NIST TN 1297)
    ``k`` times the standard deviation of the log residuals, taken back to ``K``:

    .. math:: \Delta K = K \left(e^{k s} - 1\right), \qquad k = 2 \text{ by default}

    so that the upper band edge is exactly the log-scale expanded uncertainty,
    :math:`\ln(K + \Delta K) = \ln K + k s`. That is the edge the robust optimiser constrains for
    every maximum (force, roughness, power: ``ln(K + ΔK) + e·x ≤ ln(limit)``, DESIGN.md), and it
    is where ``s`` is estimated (residuals of a log fit are roughly symmetric in ``ln Y``, not in
    ``Y``). The first-order form ``K·k·s`` would put the upper edge at
    :math:`\ln K + \ln(1 + ks)`, below ``ln K + ks`` by about :math:`(ks)^2/2`, which is not
    negligible for scattered data (``ks = 1`` for ``s = 0.5``). The band ``±ΔK`` is symmetric, as
    :class:`~models.powerlaw.PowerLawModel` holds it, so its lower edge ``K(2 − e^{ks})`` lies
    below the log-scale lower edge :math:`K e^{-ks}`: conservative for a minimum (tool life);
    it reaches 0 when ``ks ≥ ln 2``, i.e. when the data guarantee no positive lower value.

``coverage`` is the fraction of points inside the band by the same measure,
:math:`|Y_j - \hat Y_j| \le \Delta K \prod_i x_{ij}^{e_i}`, i.e. :math:`K |e^{r_j} - 1| \le
\Delta K`. The range band covers every point by construction (coverage 1.0); a ``2s`` band covers
the points with :math:`\ln(2 - e^{ks}) \le r_j \le ks`, at least the fraction within ``±ks`` on
the log scale (about 95 % for ``k = 2`` if the log residuals are normal).

References
----------
.. [1] Ivester & Heigel, Smart Machining Systems (NIST), "Cutting Force Models" and "Surface
   Roughness Models": models by regression of the linearised power law; "Model uncertainties
   were determined as the range of K (±ΔK) that encompasses all of the points in the data set."
.. [2] Taylor & Kuyatt, Guidelines for Evaluating and Expressing the Uncertainty of NIST
   Measurement Results, NIST Technical Note 1297 (1994), Sec. 6: expanded uncertainty
   ``U = k·u_c`` with coverage factor ``k = 2`` (about 95 %).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
import numpy.typing as npt

from models.errors import InputError

Band = Literal["range", "2s"]
#: The band kinds, as ``band`` takes them.
BANDS: tuple[Band, ...] = ("range", "2s")

#: Relative rounding allowance when testing whether a point lies inside the band.
COVERAGE_RTOL = 1e-12

FloatArray = npt.NDArray[np.float64]


def band_dK(
    K: float, s: float, log_residuals: Sequence[float] | FloatArray, band: Band, k: float = 2.0
) -> float:
    r"""Half-width ``ΔK`` of the band on ``K``.

    Parameters
    ----------
    K : float
        Fitted coefficient [unit of the response].
    s : float
        Standard deviation of the log residuals [-].
    log_residuals : sequence of float
        ``ln Y_j − ln Ŷ_j`` [-].
    band : {"range", "2s"}
        ``"range"``: :math:`K \max_j |e^{r_j} - 1|`, the smallest band holding every point
        (Ivester & Heigel, "Cutting Force Models"). ``"2s"``: :math:`K (e^{k s} - 1)`, the
        log-scale expanded uncertainty ``k·s`` (NIST TN 1297) at the upper edge.
    k : float
        Coverage factor of the ``"2s"`` band [-].

    Returns
    -------
    float
        ``ΔK`` [unit of the response].
    """
    if band == "range":
        relative = np.abs(np.expm1(np.asarray(log_residuals, dtype=np.float64)))
        return K * float(np.max(relative, initial=0.0))
    return K * math.expm1(k * s)


def coverage(K: float, dK: float, log_residuals: Sequence[float] | FloatArray) -> float:
    r"""Fraction of the points inside the band ``(K ± ΔK) · Π x_i^e_i``.

    A point is inside when :math:`|Y_j - \hat Y_j| \le \Delta K \prod_i x_{ij}^{e_i}`, that is
    :math:`K |e^{r_j} - 1| \le \Delta K` (with a relative rounding allowance of
    :data:`COVERAGE_RTOL`), the same measure :func:`band_dK` uses for the range band.

    Parameters
    ----------
    K : float
        Fitted coefficient [unit of the response].
    dK : float
        Half-width of the band [unit of the response].
    log_residuals : sequence of float
        ``ln Y_j − ln Ŷ_j`` [-].

    Returns
    -------
    float
        Covered fraction in [0, 1].
    """
    r = np.asarray(log_residuals, dtype=np.float64)
    if r.size == 0:
        return 1.0
    inside = K * np.abs(np.expm1(r)) <= dK * (1.0 + COVERAGE_RTOL)
    return float(np.mean(inside))


def check_band(band: str, k: float) -> float | None:
    """Check the band kind and ``k``; the ``k`` to report (None for the range band)."""
    if band not in BANDS:
        raise InputError("band", band, f"unknown band; expected one of: {', '.join(BANDS)}")
    if band == "range":
        return None
    if isinstance(k, bool) or not (math.isfinite(k) and k > 0):
        raise InputError("k", k, "the coverage factor must be a positive finite number")
    return float(k)
