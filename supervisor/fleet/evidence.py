r"""What one operation's readings say about its tool's model, in the tool's own parameters.

``learn``'s posterior of an operation (:mod:`supervisor.rcb.posterior`) is over
``β = (ln Y(c), e_1 … e_n[, w])``: the intercept at the log-centre ``c`` of the operation's
bounds box, with the context inputs (a diameter, a wear land) folded in at their catalogue
exponents. Two operations of one tool share the tool's law ``ln y = ln K + Σ e_i ln x_i +
Σ_j e_j ln x_j`` (``j`` over the context), so the tool's parameters are

.. math:: θ = (\ln K, e_1 … e_n) = T β_{0..n} + o, \qquad
   T = \begin{pmatrix} 1 & −c^\mathsf{T} \\ 0 & I \end{pmatrix}, \quad
   o = (−Σ_j e_j \ln x_j, 0 … 0)

A wearing quantity (:data:`~supervisor.rcb.posterior.WEARING`) has one more parameter, the
rise of ``ln y`` over an edge's life, ``ω = n_max w`` (``w`` the learner's edge-age coefficient
per part, ``n_max`` the parts an edge makes before its last, so ``T``'s last diagonal entry is
``n_max``): an edge is changed at the plan's ``parts_per_edge``, set at the tool's wear
criterion (ISO 3685's flank wear VB = 0.3 mm, say), so the rise it makes by then is the tool's
on the material as its exponents are, whatever the operation's parts take, up to a machine's
own (:data:`~supervisor.fleet.hierarchy.DEFAULT_EDGE_SPREAD`). An operation without
an edge limit says nothing of ``ω``: its belief gets ``ω ~ N(0, edge_sd²)``, the catalogue's
(:data:`~supervisor.rcb.posterior.DEFAULT_EDGE_SD`), uncorrelated, and its evidence none.
A Gaussian belief maps to ``N(T μ + o, T Σ T^\mathsf{T})``.

The *evidence* of the readings is their own information about ``β``, ``(J, h)``, which a
belief keeps and every update moves as it moves the belief (:mod:`supervisor.rcb.information`:
a change's discount steps it, so a process that changed teaches the fleet what its readings
say of the process as it is now), mapped to ``θ`` (the product of Gaussians [1]_):
``J_θ = T^{-T} J T^{-1}``, ``h_θ = T^{-T} h + J_θ o``. A belief stored before 2026-12-06
keeps none: its evidence is the posterior less the prior it started from, ``J = P − P₀``,
``h = P m − P_0 m_0`` with ``P = (TΣT^\mathsf{T})^{-1}``, projected on the eigenvectors of
positive eigenvalue where a discount left less precision than the prior's (which mixes the
discount's loss in ``ln K`` with the exponents' evidence: the reason the readings' own are
kept). Either is the same without a discount.

References
----------
.. [1] Bishop, Pattern Recognition and Machine Learning (2006), §2.3.3 (Bayes' theorem for
   Gaussian variables; the information form).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from supervisor.rcb.information_form import positive_parts
from supervisor.rcb.posterior import DEFAULT_EDGE_SD, WEARING, Posterior


@dataclass(frozen=True)
class Evidence:
    """The information ``(J, h)`` about ``θ = (ln K, e…)`` of one tool's quantity.

    ``names``: the exponents of ``θ`` after ``ln K``; ``readings``: the measurements behind it.
    """

    names: tuple[str, ...]
    information: np.ndarray  # J, (n + 1) x (n + 1)
    vector: np.ndarray  # h, n + 1
    readings: int

    def __add__(self, other: Evidence) -> Evidence:
        if other.names != self.names:
            raise ValueError(f"evidence over {other.names} added to evidence over {self.names}")
        return Evidence(
            self.names,
            self.information + other.information,
            self.vector + other.vector,
            self.readings + other.readings,
        )


def size(belief: Posterior) -> int:
    """The length of ``θ`` of ``belief``'s quantity: ``ln K``, exponents, a wearing one's ``ω``."""
    return len(belief.names) + (2 if belief.quantity in WEARING else 1)


def transform(belief: Posterior, context: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """``T`` and ``o`` of ``belief`` (module docstring): ``θ = T β + o``.

    Over ``β``'s own length: ``ω`` only where ``belief`` has the edge feature.
    """
    n = len(belief.names)
    t = np.eye(n + 2 if belief.edge_max else n + 1)
    t[0, 1 : n + 1] = -np.array(belief.center)
    if belief.edge_max:
        t[n + 1, n + 1] = belief.edge_max
    offset = np.zeros(len(t))
    offset[0] = -sum(e * math.log(context[name]) for name, e in belief.context_exponents.items())
    return t, offset


#: The least variance a belief about ``θ`` may have in any direction (a standard deviation of
#: 1e-6 in ``ln y``, a ppm of K) for its evidence to be made: ``J = P − P₀`` is a difference
#: of precisions, each known to about 2.2e-16 of its largest, so a precision of 1/1e-12 leaves
#: ``J`` wrong by about 2e-4, where a reading at a 2 % noise gives 2500. A tool whose band is
#: 1e-9 of its K (a hand-written ``dK``) made precisions of 1e18 and a fleet law of
#: ``K = 1.8e-8`` with a feed exponent of −17.8 from two readings.
LEAST_VARIANCE = 1e-12


def least_variance(belief: Posterior) -> float:
    """The smallest eigenvalue of ``θ``'s covariance under ``belief`` (``T Σ Tᵀ``).

    :func:`_stacked`'s, at any context (it moves the mean only): a wearing quantity's ``ω``
    without an edge feature is at the catalogue's ``N(0, edge_sd²)``.
    """
    _, cov = _stacked([(belief, dict.fromkeys(belief.context_exponents, 1.0))])
    return float(np.linalg.eigvalsh(0.5 * (cov[0] + cov[0].T))[0])


def in_tool_terms(
    belief: Posterior, context: Mapping[str, float], edge_sd: float = DEFAULT_EDGE_SD
) -> tuple[np.ndarray, np.ndarray]:
    """The mean and covariance of ``θ`` under ``belief``.

    ``ω`` is at ``N(0, edge_sd²)`` where the belief has no edge feature and the quantity wears;
    at the default ``edge_sd`` where a plan set it to 0 (its own edges do not wear, other
    plans' may, and ``θ``'s belief must be proper).
    """
    mean, cov = _stacked([(belief, context)], edge_sd)
    return mean[0], cov[0]


def evidence(posterior: Posterior, prior: Posterior, context: Mapping[str, float]) -> Evidence:
    """The readings' information about ``θ``: ``posterior`` less the ``prior`` it started from."""
    return evidences([(posterior, prior, context)])[0]


def evidences(
    beliefs: Sequence[tuple[Posterior, Posterior, Mapping[str, float]]],
) -> list[Evidence]:
    """:func:`evidence` of each ``(posterior, prior, context)``, in order.

    Beliefs of one shape are stacked and go through numpy's stacked inverse and
    eigendecomposition at once (a new plan's fleet prior reads thousands).
    """
    groups: dict[tuple[int, bool, int, bool], list[int]] = {}
    for index, (posterior, prior, _) in enumerate(beliefs):
        if posterior.names != prior.names or posterior.edge_max != prior.edge_max:
            raise ValueError(
                f"posterior over {posterior.names} (edge {posterior.edge_max}), "
                f"prior over {prior.names} (edge {prior.edge_max})"
            )
        kept = posterior.readings_information is not None
        shape = (len(posterior.names), bool(posterior.edge_max), size(posterior), kept)
        groups.setdefault(shape, []).append(index)
    out: list[Evidence | None] = [None] * len(beliefs)
    for (*_, kept), indices in groups.items():
        chosen = [beliefs[i] for i in indices]
        j, h = positive_parts(*(_kept(chosen) if kept else _difference(chosen)))
        for row, (index, (posterior, _, _)) in enumerate(zip(indices, chosen, strict=True)):
            out[index] = Evidence(posterior.names, j[row], h[row], posterior.observations)
    return [e for e in out if e is not None]


def _kept(
    beliefs: Sequence[tuple[Posterior, Posterior, Mapping[str, float]]],
) -> tuple[np.ndarray, np.ndarray]:
    """The readings' own ``(J, h)`` of beliefs that keep them, about ``θ``, stacked.

    ``θ = T β + o`` (:func:`transform`): ``J_θ = T⁻ᵀ J T⁻¹``, ``h_θ = T⁻ᵀ h + J_θ o``; a
    wearing quantity's ``ω`` without the edge feature: no evidence.
    """
    frames = [transform(posterior, context) for posterior, _, context in beliefs]
    t_inv = np.linalg.inv(np.array([frame for frame, _ in frames]))
    t_inv_t = np.swapaxes(t_inv, -1, -2)
    offset = np.array([o for _, o in frames])
    j = t_inv_t @ np.array([p.readings_information for p, _, _ in beliefs]) @ t_inv
    vector = np.array([p.readings_vector for p, _, _ in beliefs])[..., np.newaxis]
    h = (t_inv_t @ vector + j @ offset[..., np.newaxis])[..., 0]
    extra = size(beliefs[0][0]) - j.shape[-1]
    return np.pad(j, ((0, 0), (0, extra), (0, extra))), np.pad(h, ((0, 0), (0, extra)))


def _difference(
    beliefs: Sequence[tuple[Posterior, Posterior, Mapping[str, float]]],
) -> tuple[np.ndarray, np.ndarray]:
    """``P − P₀`` and ``P m − P₀ m₀`` about ``θ`` of beliefs stored before 2026-12-06, stacked."""
    m, s = _stacked([(b[0], b[2]) for b in beliefs])
    m0, s0 = _stacked([(b[1], b[2]) for b in beliefs])
    p, p0 = np.linalg.inv(s), np.linalg.inv(s0)
    return p - p0, (p @ m[..., np.newaxis] - p0 @ m0[..., np.newaxis])[..., 0]


def _stacked(
    beliefs: Sequence[tuple[Posterior, Mapping[str, float]]], edge_sd: float = DEFAULT_EDGE_SD
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`in_tool_terms` of beliefs of one shape, stacked: means ``(N, k)``, covariances."""
    frames = [transform(belief, context) for belief, context in beliefs]
    t = np.array([frame for frame, _ in frames])
    k = t.shape[-1]
    means = np.array([belief.mean[:k] for belief, _ in beliefs])
    covs = np.array([belief.cov for belief, _ in beliefs])[:, :k, :k]
    mean = (t @ means[..., np.newaxis])[..., 0] + np.array([offset for _, offset in frames])
    cov = t @ covs @ np.swapaxes(t, -1, -2)
    if size(beliefs[0][0]) > k:
        mean = np.concatenate([mean, np.zeros((len(beliefs), 1))], axis=1)
        cov = np.pad(cov, ((0, 0), (0, 1), (0, 1)))
        cov[:, k, k] = (edge_sd if edge_sd > 0 else DEFAULT_EDGE_SD) ** 2
    return mean, cov


def in_operation_terms(
    catalogue: Posterior, context: Mapping[str, float], mean: np.ndarray, cov: np.ndarray
) -> Posterior:
    """``θ ~ N(mean, cov)`` as ``catalogue``'s ``β``, :func:`in_tool_terms`' inverse.

    ``ω`` is left out where ``catalogue`` has no edge feature.
    """
    t, offset = transform(catalogue, context)
    k = len(t)
    t_inv = np.linalg.inv(t)
    beta = t_inv @ (mean[:k] - offset)
    sigma = t_inv @ cov[:k, :k] @ t_inv.T
    sigma = 0.5 * (sigma + sigma.T)
    assert len(beta) == len(catalogue.mean)
    return replace(
        catalogue,
        mean=tuple(float(v) for v in beta),
        cov=tuple(tuple(float(v) for v in row) for row in sigma),
    )
