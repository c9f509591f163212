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

Every point :math:`j` implies its own coefficient :math:`K_j = Y_j / \prod_i x_{ij}^{e_i}`
(fitted and fixed exponents), and :math:`K_j / K = \exp(r_j)`. The band ``ΔK`` is one of:

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
.. [3] N. R. Draper & H. Smith, Applied Regression Analysis, 3rd ed. (1998), Ch. 5: least
   squares in matrix form, ``V(b) = (XᵀX)⁻¹ σ²`` estimated with ``s²``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
import numpy.typing as npt

from models.errors import InputError
from models.powerlaw import PowerLawModel

Band = Literal["range", "2s"]
#: The band kinds, as ``band`` takes them.
BANDS: tuple[Band, ...] = ("range", "2s")

#: Name of the intercept in ``stderr`` and ``parameters``.
LN_K = "ln_K"

#: Smallest ratio of the least to the largest singular value of the centred, column-scaled log
#: design; below it the free columns are taken as collinear (about ``sqrt(machine epsilon)``:
#: half the significant digits of the estimates would be lost).
MIN_SINGULAR_RATIO = 1e-8

#: A log column whose spread is below this (times its magnitude, at least 1) is constant.
CONSTANT_RTOL = 1e-12

#: Relative rounding allowance when testing whether a point lies inside the band.
COVERAGE_RTOL = 1e-12

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class FitResult:
    """A fitted power law ``Y = K · Π x_i^e_i`` with its statistics and band.

    Parameters
    ----------
    K : float
        Coefficient ``exp(ln K)`` [unit of the response].
    dK : float
        Half-width of the band on K [unit of the response] (see :func:`band_dK`).
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
        Fraction of the points inside ``(K ± dK) · Π x_i^e_i`` [-] (see :func:`coverage`).
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
        checked_k = _check_band(band, k)
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
    fixed = dict(fixed or {})
    labels = dict(labels or {})
    checked_k = _check_band(band, k)
    names = list(variables)
    y_raw = _vector(response, response_name)
    n = y_raw.size
    columns = {name: _vector(variables[name], labels.get(name, name)) for name in names}
    for name, column in columns.items():
        if column.size != n:
            raise InputError(
                labels.get(name, name),
                f"{column.size} values",
                f"the response {response_name} has {n}; every column needs one value per point",
            )
    row_names = list(rows) if rows is not None else list(range(n))
    if len(row_names) != n:
        raise InputError("rows", f"{len(row_names)} labels", f"expected one per point ({n})")
    _check_positive(y_raw, response_name, row_names)
    for name, column in columns.items():
        _check_positive(column, labels.get(name, name), row_names)
    for name, exponent in fixed.items():
        if not math.isfinite(exponent):
            raise InputError(f"fixed.{name}", exponent, "must be a finite number")
        if name not in columns and exponent != 0.0:
            raise InputError(
                f"fixed.{name}", exponent, f"a fixed exponent other than 0 needs the {name} values"
            )

    free = [name for name in names if name not in fixed]
    p = 1 + len(free)
    if n <= p:
        params = ", ".join([LN_K, *free])
        raise InputError(
            "n",
            n,
            f"{n} points cannot fit {p} parameters ({params}) and leave a residual to estimate "
            f"s; need at least {p + 1}",
        )
    logs = {name: np.log(column) for name, column in columns.items()}
    y = np.log(y_raw)
    for name, exponent in fixed.items():
        if name in logs:
            y = y - exponent * logs[name]
    free_logs = [logs[name] for name in free]
    _check_design(free, [columns[name] for name in free], free_logs, labels)

    X = np.column_stack([np.ones(n), *free_logs])
    q, r_factor = np.linalg.qr(X)
    r_inv = np.linalg.inv(r_factor)
    beta = r_inv @ (q.T @ y)
    residuals = y - X @ beta
    ssr = float(residuals @ residuals)
    dof = n - p
    s = math.sqrt(ssr / dof)
    covariance = (s * s) * (r_inv @ r_inv.T)
    stderr_values = np.sqrt(np.diag(covariance))
    centred = y - float(np.mean(y))
    sst = float(centred @ centred)
    r2 = _r_squared(ssr, sst, y)

    K = math.exp(float(beta[0]))
    fitted = {name: float(beta[i + 1]) for i, name in enumerate(free)}
    exponents = {name: fitted[name] if name in fitted else fixed[name] for name in names}
    exponents.update({name: e for name, e in fixed.items() if name not in exponents})
    dK = band_dK(K, s, residuals, band, k)
    parameters = (LN_K, *free)
    return FitResult(
        K=K,
        dK=dK,
        exponents=exponents,
        fixed=fixed,
        stderr={name: float(stderr_values[i]) for i, name in enumerate(parameters)},
        parameters=parameters,
        covariance=tuple(tuple(float(c) for c in row) for row in covariance),
        s=s,
        n=n,
        r2=r2,
        log_residuals=tuple(float(r) for r in residuals),
        band=band,
        k=checked_k,
        coverage=coverage(K, dK, residuals),
    )


def _check_band(band: str, k: float) -> float | None:
    """Check the band kind and ``k``; the ``k`` to report (None for the range band)."""
    if band not in BANDS:
        raise InputError("band", band, f"unknown band; expected one of: {', '.join(BANDS)}")
    if band == "range":
        return None
    if isinstance(k, bool) or not (math.isfinite(k) and k > 0):
        raise InputError("k", k, "the coverage factor must be a positive finite number")
    return float(k)


def _vector(values: Sequence[float] | FloatArray, label: str) -> FloatArray:
    """A 1-D float array, or an InputError naming ``label``."""
    try:
        array = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(label, values, f"must be a list of numbers ({err})") from None
    if array.ndim != 1:
        raise InputError(label, f"shape {array.shape}", "must be a one-dimensional column")
    return array


def _check_positive(values: FloatArray, label: str, rows: Sequence[object]) -> None:
    """Refuse the first value that has no logarithm (not finite, zero or negative)."""
    bad = np.flatnonzero(~(np.isfinite(values) & (values > 0)))
    if bad.size:
        i = int(bad[0])
        value = float(values[i])
        reason = (
            "must be a finite number"
            if not math.isfinite(value)
            else "must be greater than 0 (the power law is fitted on logarithms)"
        )
        raise InputError(f"{label}[{rows[i]}]", value, reason)


def _check_design(
    free: list[str], values: list[FloatArray], logs: list[FloatArray], labels: Mapping[str, str]
) -> None:
    """Refuse constant and collinear free log columns, naming the column."""
    for name, raw, column in zip(free, values, logs, strict=True):
        spread = float(np.ptp(column))
        if spread <= CONSTANT_RTOL * max(1.0, float(np.max(np.abs(column)))):
            raise InputError(
                labels.get(name, name),
                float(raw[0]),
                f"constant column: every point has this {name}, so its exponent cannot be "
                "fitted; fix the exponent or leave the variable out",
            )
    if len(free) < 2:
        return
    centred = np.column_stack([c - float(np.mean(c)) for c in logs])
    scaled = centred / np.linalg.norm(centred, axis=0)
    _, singular, vt = np.linalg.svd(scaled, full_matrices=False)
    ratio = float(singular[-1] / singular[0])
    if ratio >= MIN_SINGULAR_RATIO:
        return
    null = np.abs(vt[-1])
    involved = [i for i in range(len(free)) if null[i] > 0.01 * float(np.max(null))]
    last = involved[-1]
    others = involved[:-1]
    name = free[last]
    basis = np.column_stack([np.ones(logs[last].size), *(logs[i] for i in others)])
    coef, *_ = np.linalg.lstsq(basis, logs[last], rcond=None)
    relation = f"ln {name} = {_tidy(float(coef[0])):.4g}"
    for c, i in zip(coef[1:], others, strict=True):
        c = _tidy(float(c))
        relation += f" {'-' if c < 0 else '+'} {abs(c):.4g}·ln {free[i]}"
    with_names = ", ".join(_named(free[i], labels) for i in others)
    raise InputError(
        labels.get(name, name),
        relation,
        f"collinear with {with_names} (least/largest singular value of the scaled log design "
        f"{ratio:.2g} < {MIN_SINGULAR_RATIO:g}): their exponents cannot be told apart; fix one "
        "exponent or leave a variable out",
    )


def _named(name: str, labels: Mapping[str, str]) -> str:
    """``label (name)``, or ``name`` when it has no other label."""
    label = labels.get(name, name)
    return name if label == name else f"{label} ({name})"


def _tidy(value: float) -> float:
    """``value`` with rounding noise below 1e-9 shown as 0."""
    return 0.0 if abs(value) < 1e-9 else value


def _r_squared(ssr: float, sst: float, y: FloatArray) -> float:
    """``1 − SSR/SST``; 1.0 when the left-hand side is constant (and so fitted exactly)."""
    scale = max(1.0, float(np.max(np.abs(y)))) ** 2 * y.size
    if sst <= 1e-24 * scale:
        return 1.0
    return 1.0 - ssr / sst
