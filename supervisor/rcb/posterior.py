r"""The ``learn`` strategy's model: a Bayesian regression of the whole power law, and its cone.

Per operation and constrained quantity the power law ``y = K Π x_i^{e_i}`` is linear in
logarithms, ``ln y = β · φ(x)`` with ``φ(x) = (1, ln x_1 − c_1, …, ln x_n − c_n)`` over the
operation's cutting parameters that the model uses (the context, e.g. a fixed diameter, is
folded into the intercept) and ``c`` the log-centre of the operation's bounds box, so that the
intercept is ``ln Y`` at the centre of the box, where the catalogue data lie.

Prior (the catalogue model): ``β ~ N(μ₀, Σ₀)`` with ``μ₀ = (ln Y_model(c), e_1, …, e_n)`` and a
diagonal ``Σ₀``: the band read as ``k σ`` of the intercept, ``σ₀ = (ΔK/K)/k`` (as ``bayes``),
and for each exponent its fit's standard error where the model carries one
(``exponent_stderr``, which ``rcb fit --write-tool`` writes), else ``s_e |e_i|``
(:data:`DEFAULT_EXPONENT_SD`: a relative standard error of 15 %, three times the spread of the
virtual machine's true exponents and the order of the standard errors ``rcb fit`` reports for
the paper's data sets). Only the errors, not the covariance of the fit, are carried.

Observation: a measurement ``y ± u`` (expanded, ``k = 2``) at setpoint ``x`` observes
``ln y = β · φ(x) + ε``, ``ε ~ N(0, ((u/k)/y)²)``. Before each observation the intercept takes a
random-walk step ``τ²`` (the discrepancy: tool wear drifts, a model is never exact); the update
is the Kalman / recursive-least-squares step of Bayesian linear regression [1]_:

.. math::

    Σ_- = Σ + τ² e_0 e_0^T, \quad s² = φ^T Σ_- φ + σ_ε², \quad
    g = Σ_- φ / s², \quad μ' = μ + g (\ln y − φ^T μ), \quad Σ' = Σ_- − g φ^T Σ_-

The robust constraint handed to the optimiser at ``x`` is the ellipsoidal robust counterpart
of ``β · φ(x) <= ln(limit)`` over the credible ellipsoid ``{β : (β − μ)^T Σ^{-1} (β − μ) <= z²}``
(Ben-Tal & Nemirovski [2]_), with the next part's random-walk step included:

.. math:: μ · φ(x) + z \sqrt{φ(x)^T (Σ + τ² e_0 e_0^T) φ(x) + v_x} <= \ln(\mathrm{limit})

``v_x = Σ (e_i Δx_i/x_i)² / k²`` carries the plan's setpoint uncertainties as the band does
(GUM, :mod:`models.powerlaw`). Minima mirror it (``μ · φ − z √… >= ln(limit)``). ``φ`` is affine
in ``x``, so the constraint is a second-order cone in ``ln x``: :mod:`supervisor.optimize.highs_lp`
solves it by outer-approximation cuts. ``z`` (:data:`DEFAULT_Z`) is chosen by the closed-loop
benchmark over 1000 scenarios (README); it is larger than a normal quantile would be because
the true process need not be a power law over the whole box and the prior is only as good as
the catalogue.

Tool wear: force, roughness and spindle current rise as an edge wears (Ivester & Heigel's tool
life model, Eq. 8, ends each edge at the allowable flank wear). For an operation with a
``parts_per_edge`` limit the regression has one more feature, the parts the edge made before
this one, ``n`` (the MES reports it per operation as ``edge_parts``), with a prior
``N(0, (s_w / n_max)²)`` on its coefficient (:data:`DEFAULT_EDGE_SD`: a rise of ``s_w`` over an
edge's life as one standard deviation) and ``n_max = parts_per_edge − 1``. The cone must hold
for every part the edge makes, and is convex in ``n``, so it is imposed at ``n = 0`` and at
``n = n_max``. A report without ``edge_parts`` is read at ``n_max / 2`` with the coefficient's
spread over half a life added to its noise.

Assumptions: the exponents are constant over the box (the power law holds), noise is Gaussian
in logarithms with the reported uncertainty as ``2σ``, and drift is a random walk of the
intercept. What the strategy promises is that of the band: the limit holds at the edge of
what is still uncertain.

References
----------
.. [1] Bishop, Pattern Recognition and Machine Learning (2006), §3.3 (Bayesian linear
   regression, sequential update); Gelman et al., Bayesian Data Analysis, 3rd ed., §14.2.
.. [2] Ben-Tal & Nemirovski, "Robust solutions of uncertain linear programs", Operations
   Research Letters 25 (1999): the robust counterpart of a linear constraint over an
   ellipsoid is a second-order cone.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from models import kinematics
from models.powerlaw import PowerLawModel
from models.quantities import PARTS_PER_EDGE
from supervisor.inputs.part_report import Measurement
from supervisor.inputs.plan import Operation
from supervisor.rcb import information_form as form

#: The cone's multiple of the posterior standard deviation (README, closed-loop benchmark).
DEFAULT_Z = 4.0
#: Prior standard deviation of an exponent relative to its value, without a fitted covariance.
DEFAULT_EXPONENT_SD = 0.15
#: Prior standard deviation of the rise over one edge's life, in ln of the quantity [-]: a
#: 10 % rise as one standard deviation (the virtual machine's benchmark drift is 5 %).
DEFAULT_EDGE_SD = 0.1
#: Quantities that rise as an edge wears, and so get the edge-age feature.
WEARING = ("force_N", "roughness_um", "spindle_current_A")
#: Relative jitter of the covariance's Cholesky factor (numerical safety only).
_JITTER = 1e-12


@dataclass(frozen=True)
class Posterior:
    """Posterior ``N(mean, cov)`` of ``β = (ln Y(c), e_1, …, e_n[, w])`` of one quantity.

    Parameters
    ----------
    quantity : str
        The model quantity (``force_N`` …).
    names : tuple[str, ...]
        The cutting parameters ``x_1 … x_n`` of ``φ``.
    center : tuple[float, ...]
        ``c_i``, the log-centre of the operation's bounds for each name.
    context_exponents : Mapping[str, float]
        Exponents of the context inputs, folded into the intercept (kept for the model view).
    mean : tuple[float, ...]
        ``μ``, length ``n + 1`` (``n + 2`` with the edge feature, its coefficient ``w`` last).
    cov : tuple[tuple[float, ...], ...]
        ``Σ``, square, of the same size.
    observations : int
        Measurements applied so far.
    edge_max : int
        ``n_max``, the most parts an edge makes before this one; 0: no edge feature.
    noise_scale2 : float
        ``λ``, the noise variance's scale the readings' precision is counted at
        (:func:`supervisor.rcb.learning.rescaled`; 1: as reported).
    prior_widening : float
        The variance the start prior's intercept was grown by when the readings rejected it
        (a fleet prior: :mod:`supervisor.rcb.prior_check`; a reading past the band beyond its
        spread: :mod:`supervisor.rcb.learning`; 0: the prior as it started).
    band_veto_z : float
        A fleet prior's: the confidence at which its cones veto the catalogue band's optimum,
        where the fleet's machines differ by more than the band (:mod:`supervisor.fleet.prior`;
        0: at the mean, as every catalogue start). An update does not carry it on.
    readings_information, readings_vector : optional
        ``(J, h)``, what the readings alone say of ``β`` at ``noise_scale2``, moved by every
        update as the belief is (:mod:`supervisor.rcb.information`); None: a belief stored
        before they were kept.
    """

    quantity: str
    names: tuple[str, ...]
    center: tuple[float, ...]
    context_exponents: Mapping[str, float]
    mean: tuple[float, ...]
    cov: tuple[tuple[float, ...], ...]
    observations: int = 0
    edge_max: int = 0
    noise_scale2: float = 1.0
    prior_widening: float = 0.0
    band_veto_z: float = 0.0
    readings_information: tuple[tuple[float, ...], ...] | None = None
    readings_vector: tuple[float, ...] | None = None

    def cholesky(self, drift: float) -> np.ndarray:
        """The Cholesky factor of ``Σ + drift² e₀e₀ᵀ`` (kept on the object: it is immutable)."""
        cache: dict[float, np.ndarray] = self.__dict__.setdefault("_cholesky", {})
        if drift not in cache:
            cov = np.array(self.cov)
            cov[0, 0] += drift**2
            scale = max(float(np.max(np.abs(np.diag(cov)))), 1e-300)
            cache[drift] = np.linalg.cholesky(cov + np.eye(len(cov)) * scale * _JITTER)
        return cache[drift]

    @property
    def mean_array(self) -> np.ndarray:
        """``μ`` as an array (kept on the object: it is immutable)."""
        cache: dict[str, np.ndarray] = self.__dict__.setdefault("_arrays", {})
        if "mean" not in cache:
            cache["mean"] = np.array(self.mean)
        return cache["mean"]

    @property
    def precision(self) -> np.ndarray:
        """``Σ⁻¹`` (kept on the object: it is immutable; callers must not write to it)."""
        cache: dict[str, np.ndarray] = self.__dict__.setdefault("_arrays", {})
        if "precision" not in cache:
            cache["precision"] = np.linalg.inv(np.array(self.cov))
        return cache["precision"]

    @property
    def precision_norm(self) -> float:
        """The largest ``|eigenvalue|`` of ``Σ⁻¹`` (kept on the object)."""
        cache: dict[str, float] = self.__dict__.setdefault("_numbers", {})
        if "precision_norm" not in cache:
            cache["precision_norm"] = float(np.abs(np.linalg.eigvalsh(self.precision)).max())
        return cache["precision_norm"]

    @property
    def edges(self) -> tuple[int, ...]:
        """The edge ages a cone is imposed at: 0 and ``n_max`` (only 0 without the feature)."""
        return (0, self.edge_max) if self.edge_max else (0,)

    def features(self, point: Mapping[str, float], edge_parts: float = 0.0) -> np.ndarray:
        """``φ(x[, n]) = (1, ln x_i − c_i[, n])`` at ``point``."""
        logs = [math.log(point[n]) - c for n, c in zip(self.names, self.center, strict=True)]
        return np.array([1.0, *logs, *((edge_parts,) if self.edge_max else ())])

    def edge_age(self, edge_parts: int | None) -> float:
        """``n`` of a reading: its edge's age up to ``n_max``, ``n_max / 2`` when not known."""
        n = float(edge_parts) if edge_parts is not None else self.edge_max / 2.0
        return min(n, float(self.edge_max))

    @property
    def exponent_means(self) -> tuple[float, ...]:
        """The posterior means of the exponents, in :attr:`names` order."""
        return self.mean[1 : 1 + len(self.names)]

    def model(self, dK: float = 0.0, edge_parts: float = 0.0) -> PowerLawModel:
        """The posterior mean as a power law ``K Π x_i^{μ_i}`` (context and edge in ``K``).

        Kept on the object once made (it is immutable), per ``dK`` and edge age.
        """
        cache: dict[tuple[float, float], PowerLawModel] = self.__dict__.setdefault("_models", {})
        key = (dK, edge_parts)
        if key not in cache:
            cache[key] = self._model(dK, edge_parts)
        return cache[key]

    def _model(self, dK: float, edge_parts: float) -> PowerLawModel:
        mu = self.exponent_means
        ln_K = self.mean[0] - sum(m * c for m, c in zip(mu, self.center, strict=True))
        if self.edge_max:
            ln_K += self.mean[-1] * edge_parts
        exponents = {n: float(m) for n, m in zip(self.names, mu, strict=True)}
        return PowerLawModel(
            self.quantity,
            math.exp(ln_K),
            dK,
            exponents,
            "posterior (learn)",
            f"{self.observations} measurements",
        )

    def to_json(self) -> dict[str, object]:
        """A JSON-able mapping (:func:`from_json` reads it back exactly)."""
        widening: dict[str, object] = {}
        if self.prior_widening:
            widening["prior_widening"] = self.prior_widening
        if self.band_veto_z:
            widening["band_veto_z"] = self.band_veto_z
        if self.readings_information is not None and self.readings_vector is not None:
            widening["readings_information"] = [list(r) for r in self.readings_information]
            widening["readings_vector"] = list(self.readings_vector)
        return {
            "quantity": self.quantity,
            "names": list(self.names),
            "center": list(self.center),
            "context_exponents": dict(self.context_exponents),
            "mean": list(self.mean),
            "cov": [list(r) for r in self.cov],
            "observations": self.observations,
            "edge_max": self.edge_max,
            "noise_scale2": self.noise_scale2,
            **widening,
        }


def from_json(data: Mapping[str, object]) -> Posterior:
    """The :class:`Posterior` of :meth:`Posterior.to_json`."""
    cov, rows, vector = data["cov"], data.get("readings_information"), data.get("readings_vector")
    assert isinstance(cov, list)
    assert rows is None or isinstance(rows, list)
    assert vector is None or isinstance(vector, list)
    return Posterior(
        quantity=str(data["quantity"]),
        names=tuple(str(n) for n in data["names"]),  # type: ignore[attr-defined]
        center=tuple(float(c) for c in data["center"]),  # type: ignore[attr-defined]
        context_exponents={
            str(k): float(v)
            for k, v in data["context_exponents"].items()  # type: ignore[attr-defined]
        },
        mean=tuple(float(m) for m in data["mean"]),  # type: ignore[attr-defined]
        cov=tuple(tuple(float(v) for v in row) for row in cov),
        observations=int(data.get("observations", 0)),  # type: ignore[call-overload]
        edge_max=int(data.get("edge_max", 0)),  # type: ignore[call-overload]
        noise_scale2=float(data.get("noise_scale2", 1.0)),  # type: ignore[arg-type]
        prior_widening=float(data.get("prior_widening", 0.0)),  # type: ignore[arg-type]
        band_veto_z=float(data.get("band_veto_z", 0.0)),  # type: ignore[arg-type]
        readings_information=None if rows is None else tuple(tuple(map(float, r)) for r in rows),
        readings_vector=None if vector is None else tuple(map(float, vector)),
    )


def edge_max_of(operation: Operation, quantity: str) -> int:
    """``n_max`` of ``operation`` for ``quantity``: ``parts_per_edge − 1`` for a wearing one."""
    parts = operation.limits.get(PARTS_PER_EDGE)
    if parts is None or quantity not in WEARING:
        return 0
    return max(math.ceil(parts) - 1, 0)


def prior(
    model: PowerLawModel,
    operation: Operation,
    coverage_k: float,
    exponent_sd: float,
    edge_sd: float = DEFAULT_EDGE_SD,
) -> Posterior:
    """The catalogue model as a prior over the operation's bounds box (module docstring)."""
    params = kinematics.PARAMETERS[operation.process]
    names = tuple(p for p in params if p in model.exponents)
    center = tuple(
        0.5 * (math.log(operation.bounds[n][0]) + math.log(operation.bounds[n][1])) for n in names
    )
    point = {**operation.context, **{n: math.exp(c) for n, c in zip(names, center, strict=True)}}
    context = {n: e for n, e in model.exponents.items() if n not in names}
    mean = [math.log(model.predict(point).value), *(model.exponents[n] for n in names)]
    variances = [((model.dK / model.K) / coverage_k) ** 2]
    variances += [
        (model.exponent_stderr[n] if n in model.exponent_stderr else exponent_sd * abs(e)) ** 2
        for n, e in ((n, model.exponents[n]) for n in names)
    ]
    edge_max = edge_max_of(operation, model.quantity)
    if edge_max:
        mean.append(0.0)
        variances.append((edge_sd / edge_max) ** 2)
    cov = tuple(
        tuple(v if i == j else 0.0 for j in range(len(variances))) for i, v in enumerate(variances)
    )
    readings, vector = form.none_yet(len(mean))
    return Posterior(
        model.quantity,
        names,
        center,
        context,
        tuple(mean),
        cov,
        0,
        edge_max,
        readings_information=readings,
        readings_vector=vector,
    )


def observe(
    belief: Posterior,
    point: Mapping[str, float],
    measurement: Measurement,
    coverage_k: float,
    drift: float,
    edge_parts: int | None = None,
) -> Posterior:
    """The posterior after ``measurement`` at ``point`` (module docstring, the update).

    ``edge_parts``: the parts the edge made before this one (None: not reported).
    """
    noise = max((measurement.uncertainty / coverage_k) / measurement.value, 1e-9)
    if belief.edge_max and edge_parts is None:  # unknown age: its spread is noise too
        w_sd = math.sqrt(belief.cov[-1][-1]) + abs(belief.mean[-1])
        noise = math.hypot(noise, w_sd * belief.edge_max / 2.0)
    phi = belief.features(point, belief.edge_age(edge_parts))
    mu = np.array(belief.mean)
    cov = np.array(belief.cov)
    cov[0, 0] += drift**2
    ln_y = math.log(measurement.value)
    readings, vector = form.observed(
        belief.readings_information, belief.readings_vector, phi, ln_y, noise, drift**2
    )
    cov_phi = cov @ phi
    s2 = float(phi @ cov_phi) + noise**2
    gain = cov_phi / s2
    mu = mu + gain * (ln_y - float(phi @ mu))
    cov = cov - np.outer(gain, cov_phi)
    cov = 0.5 * (cov + cov.T)
    return Posterior(
        belief.quantity,
        belief.names,
        belief.center,
        belief.context_exponents,
        tuple(float(m) for m in mu),
        tuple(tuple(float(v) for v in row) for row in cov),
        belief.observations + 1,
        belief.edge_max,
        belief.noise_scale2,
        belief.prior_widening,
        readings_information=readings,
        readings_vector=vector,
    )
