r"""Fit a power-law model ``Y = K · Π x_i^e_i`` to test data, with its uncertainty band ``±ΔK``.

The model is fitted by ordinary least squares on logarithms, as Ivester & Heigel fit their
force and roughness models ("regression analysis of a linearized power-law relationship through
logarithmic transformation"):

.. math::

    \ln Y_j = \ln K + \sum_i e_i \ln x_{ij} + r_j, \qquad j = 1 \dots n

Exponents that are fixed (``fixed={"speed_m_min": 0.0}``) move to the left-hand side,
:math:`\ln Y_j - \sum_{f} e_f \ln x_{fj}`, and only ``ln K`` and the free exponents are
estimated; ``p`` is their number. With the log design matrix :math:`X` (a column of ones and one
column :math:`\ln x_i` per free exponent) and the log residuals :math:`r`:

.. math::

    s^2 = \frac{r^\mathsf{T} r}{n - p}, \qquad
    \operatorname{cov}(\widehat{\ln K}, \hat e) = s^2 (X^\mathsf{T} X)^{-1}, \qquad
    R^2 = 1 - \frac{r^\mathsf{T} r}{\sum_j (y_j - \bar y)^2}

where :math:`y` is the left-hand side. ``s`` and ``R²`` are on the log scale. ``K = exp(ln K)``
is the back-transformed coefficient: the median of ``Y`` at a point if the log residuals are
symmetric, not its mean (no log-normal bias correction, as in the source models).

The band ``ΔK`` and its coverage are :mod:`models.fit_band`'s; the points on the log scale,
:mod:`models.fit_points`'s, with the checks of the data and the log design of
:mod:`models.fit_design`.

References
----------
.. [1] Ivester & Heigel, Smart Machining Systems (NIST), "Cutting Force Models" and "Surface
   Roughness Models": models by regression of the linearised power law; "Model uncertainties
   were determined as the range of K (±ΔK) that encompasses all of the points in the data set."
.. [2] Taylor & Kuyatt, Guidelines for Evaluating and Expressing the Uncertainty of NIST
   Measurement Results, NIST Technical Note 1297 (1994), Sec. 6: expanded uncertainty
   ``U = k·u_c`` with coverage factor ``k = 2`` (about 95 %).
.. [3] N. R. Draper & H. Smith, Applied Regression Analysis, 3rd ed. (1998), Ch. 5: least
   squares in matrix form, ``V(b) = (XᵀX)⁻¹ σ²`` estimated with ``s²``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from models.fit_band import Band, band_dK, check_band, coverage
from models.fit_points import LN_K, LogPoints, log_points
from models.powerlaw import PowerLawModel

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class FitResult:
    """A fitted power law ``Y = K · Π x_i^e_i`` with its statistics and band.

    Parameters
    ----------
    K : float
        Coefficient ``exp(ln K)`` [unit of the response].
    dK : float
        Half-width of the band on K [unit of the response] (see :func:`~models.fit_band.band_dK`).
    exponents : Mapping[str, float]
        Every exponent, fitted and fixed, in the order the variables were given [-].
    fixed : Mapping[str, float]
        The exponents that were fixed, not fitted [-].
    stderr : Mapping[str, float]
        Standard error of ``ln K`` (key ``"ln_K"``) and of each fitted exponent [-].
    parameters : tuple of str
        ``("ln_K", *fitted exponents)``: the order of the rows and columns of ``covariance``.
    covariance : tuple of tuple of float
        Covariance matrix ``s² (XᵀX)⁻¹`` of the estimates [-].
    s : float
        Standard deviation of the log residuals, ``sqrt(Σr²/(n − p))`` [-].
    n : int
        Number of points.
    r2 : float
        Coefficient of determination on the log scale [-] (1.0 if the left-hand side is
        constant and fitted exactly).
    log_residuals : tuple of float
        ``ln Y_j − ln Ŷ_j`` of every point, in input order [-].
    band : {"range", "2s"}
        How ``dK`` was chosen.
    k : float or None
        Coverage factor of a ``"2s"`` band; None for ``"range"``.
    coverage : float
        Fraction of the points inside ``(K ± dK) · Π x_i^e_i`` [-]
        (see :func:`~models.fit_band.coverage`).
    """

    K: float
    dK: float
    exponents: Mapping[str, float]
    fixed: Mapping[str, float]
    stderr: Mapping[str, float]
    parameters: tuple[str, ...]
    covariance: tuple[tuple[float, ...], ...]
    s: float
    n: int
    r2: float
    log_residuals: tuple[float, ...] = field(repr=False)
    band: Band
    k: float | None
    coverage: float

    @property
    def dof(self) -> int:
        """Residual degrees of freedom ``n − p``."""
        return self.n - len(self.parameters)

    @property
    def max_abs_residual_s(self) -> float:
        """Largest ``|r_j|`` in units of ``s`` [-] (inf if ``s`` is 0 and a residual is not)."""
        largest = max((abs(r) for r in self.log_residuals), default=0.0)
        if largest == 0.0:
            return 0.0
        return largest / self.s if self.s > 0 else math.inf

    def with_band(self, band: Band, k: float = 2.0) -> FitResult:
        """The same fit with another band (``k`` is used by ``"2s"`` only)."""
        checked_k = check_band(band, k)
        dK = band_dK(self.K, self.s, self.log_residuals, band, k)
        return replace(
            self,
            band=band,
            k=checked_k,
            dK=dK,
            coverage=coverage(self.K, dK, self.log_residuals),
        )

    def to_model(self, quantity: str, source: str = "fit", reference: str = "") -> PowerLawModel:
        """The fitted model as a :class:`~models.powerlaw.PowerLawModel`.

        Parameters
        ----------
        quantity : str
            What the response is, one of :data:`models.quantities.MODEL_QUANTITIES`.
        source : str
            Where the data come from (file, test series, filters).
        reference : str
            How the model was obtained; default: the fit statistics and band.

        Returns
        -------
        PowerLawModel
            ``K``, ``dK`` and the exponents; exponents fixed at 0 are left out (the variable
            does not enter the model, so a prediction need not supply it).
        """
        exponents = {
            name: e for name, e in self.exponents.items() if not (name in self.fixed and e == 0.0)
        }
        return PowerLawModel(
            quantity=quantity,
            K=self.K,
            dK=self.dK,
            exponents=exponents,
            source=source,
            reference=reference or self.describe(),
            exponent_stderr={n: self.stderr[n] for n in exponents if n in self.stderr},
        )

    def describe(self) -> str:
        """One line of provenance: method, n, R², s and band."""
        band = "range of all points" if self.band == "range" else f"{self.k:g}·s"
        text = (
            f"log-linear least squares, n = {self.n}, R² = {self.r2:.4g}, "
            f"s = {self.s:.4g} (ln), band = {band}, coverage = {self.coverage:.4g}"
        )
        if self.fixed:
            text += ", fixed: " + ", ".join(f"{n} = {e:g}" for n, e in self.fixed.items())
        return text

    def to_json(self) -> dict[str, object]:
        """A JSON-ready dict of the fit.

        Returns
        -------
        dict
            ``{"K", "dK", "exponents", "fixed", "stderr", "covariance", "s", "n", "dof", "r2",
            "coverage", "band", "k", "max_abs_residual_s"}``; ``covariance`` as
            ``{"parameters": [...], "matrix": [[...]]}``.
        """
        return {
            "K": self.K,
            "dK": self.dK,
            "exponents": dict(self.exponents),
            "fixed": dict(self.fixed),
            "stderr": dict(self.stderr),
            "covariance": {
                "parameters": list(self.parameters),
                "matrix": [list(row) for row in self.covariance],
            },
            "s": self.s,
            "n": self.n,
            "dof": self.dof,
            "r2": self.r2,
            "coverage": self.coverage,
            "band": self.band,
            "k": self.k,
            "max_abs_residual_s": self.max_abs_residual_s,
        }


def fit_power_law(
    response: Sequence[float] | FloatArray,
    variables: Mapping[str, Sequence[float] | FloatArray],
    *,
    fixed: Mapping[str, float] | None = None,
    band: Band = "range",
    k: float = 2.0,
    response_name: str = "response",
    labels: Mapping[str, str] | None = None,
    rows: Sequence[object] | None = None,
) -> FitResult:
    r"""Fit ``Y = K · Π x_i^e_i`` by least squares on logarithms.

    .. math:: \ln Y - \sum_f e_f \ln x_f = \ln K + \sum_{i \text{ free}} e_i \ln x_i + r

    Parameters
    ----------
    response : sequence of float
        Measured ``Y`` of every point [unit of the quantity]; positive and finite.
    variables : Mapping[str, sequence of float]
        Values of each input variable at every point, keyed by name with its unit
        (``depth_mm``, ``feed_mm_rev`` ...); positive and finite.
    fixed : Mapping[str, float], optional
        Exponents not to fit [-]. A fixed variable needs values in ``variables`` unless its
        exponent is 0.
    band : {"range", "2s"}
        ``"range"``: ``ΔK`` encloses every point (Ivester & Heigel); ``"2s"``:
        ``ΔK = K (e^{ks} − 1)`` (NIST TN 1297). See the module docstring.
    k : float
        Coverage factor of the ``"2s"`` band [-], positive.
    response_name : str
        How errors name the response (e.g. its CSV column).
    labels : Mapping[str, str], optional
        How errors name each variable (e.g. its CSV column); default its name.
    rows : sequence, optional
        How errors name each point (e.g. ``"row 14"``); default its index from 0.

    Returns
    -------
    FitResult
        Estimates, standard errors, covariance, ``s``, ``n``, ``R²``, band and coverage.

    Raises
    ------
    InputError
        Naming the field and value: an unknown band or bad ``k``; columns of unequal length;
        a value that is not positive and finite (row and column); a fixed exponent that is not
        finite or lacks values; fewer points than ``p + 1`` (``s`` needs a residual degree of
        freedom); a constant column; collinear columns (their log-linear relation is given).

    References
    ----------
    .. [1] Ivester & Heigel, "Cutting Force Models": regression of the linearised power law,
       band = range of K that encompasses all points.
    .. [2] Taylor & Kuyatt, NIST TN 1297 (1994), Sec. 6: expanded uncertainty ``k·u``.
    """
    checked_k = check_band(band, k)
    labels = dict(labels or {})
    points = log_points(response, variables, dict(fixed or {}), response_name, labels, rows)
    return _fit_result(points, _least_squares(points), band, k, checked_k)


@dataclass(frozen=True)
class _LeastSquares:
    """The least-squares estimates of a fit on the log scale (Draper & Smith, Ch. 5)."""

    beta: FloatArray
    residuals: FloatArray
    s: float
    covariance: FloatArray
    stderr: FloatArray
    r2: float


def _least_squares(points: LogPoints) -> _LeastSquares:
    r"""Estimate ``ln K`` and the free exponents by QR, with their covariance and ``R²``.

    .. math::

        s^2 = \frac{r^\mathsf{T} r}{n - p}, \qquad
        \operatorname{cov}(\widehat{\ln K}, \hat e) = s^2 (X^\mathsf{T} X)^{-1}
            = s^2 R^{-1} R^{-\mathsf{T}}

    References
    ----------
    .. [1] N. R. Draper & H. Smith, Applied Regression Analysis, 3rd ed. (1998), Ch. 5:
       ``V(b) = (XᵀX)⁻¹ σ²`` estimated with ``s²``.
    """
    n, y = points.n, points.y
    X = np.column_stack([np.ones(n), *points.free_logs])
    q, r_factor = np.linalg.qr(X)
    r_inv = np.linalg.inv(r_factor)
    beta = r_inv @ (q.T @ y)
    residuals = y - X @ beta
    ssr = float(residuals @ residuals)
    dof = n - (1 + len(points.free))
    s = math.sqrt(ssr / dof)
    covariance = (s * s) * (r_inv @ r_inv.T)
    stderr_values = np.sqrt(np.diag(covariance))
    centred = y - float(np.mean(y))
    sst = float(centred @ centred)
    return _LeastSquares(beta, residuals, s, covariance, stderr_values, _r_squared(ssr, sst, y))


def _fit_result(
    points: LogPoints, fit: _LeastSquares, band: Band, k: float, checked_k: float | None
) -> FitResult:
    """The :class:`FitResult` of the estimates: ``K``, every exponent, the band and coverage."""
    K = math.exp(float(fit.beta[0]))
    fixed = points.fixed
    fitted = {name: float(fit.beta[i + 1]) for i, name in enumerate(points.free)}
    exponents = {name: fitted[name] if name in fitted else fixed[name] for name in points.names}
    exponents.update({name: e for name, e in fixed.items() if name not in exponents})
    dK = band_dK(K, fit.s, fit.residuals, band, k)
    parameters = (LN_K, *points.free)
    return FitResult(
        K=K,
        dK=dK,
        exponents=exponents,
        fixed=fixed,
        stderr={name: float(fit.stderr[i]) for i, name in enumerate(parameters)},
        parameters=parameters,
        covariance=tuple(tuple(float(c) for c in row) for row in fit.covariance),
        s=fit.s,
        n=points.n,
        r2=fit.r2,
        log_residuals=tuple(float(r) for r in fit.residuals),
        band=band,
        k=checked_k,
        coverage=coverage(K, dK, fit.residuals),
    )


def _r_squared(ssr: float, sst: float, y: FloatArray) -> float:
    """``1 − SSR/SST``; 1.0 when the left-hand side is constant (and so fitted exactly)."""
    scale = max(1.0, float(np.max(np.abs(y)))) ** 2 * y.size
    if sst <= 1e-24 * scale:
        return 1.0
    return 1.0 - ssr / sst
