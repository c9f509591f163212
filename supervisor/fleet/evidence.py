r"""What one operation's readings say about its tool's model, in the tool's own parameters.

``learn``'s posterior of an operation (:mod:`supervisor.rcb.posterior`) is over
``β = (ln Y(c), e_1 … e_n[, w])``: the intercept at the log-centre ``c`` of the operation's
bounds box, with the context inputs (a diameter, a wear land) folded in at their catalogue
exponents. Two operations of one tool share the tool's law ``ln y = ln K + Σ e_i ln x_i +
Σ_j e_j ln x_j`` (``j`` over the context), so the tool's parameters are

.. math:: θ = (\ln K, e_1 … e_n) = T β_{0..n} + o, \qquad
   T = \begin{pmatrix} 1 & −c^\mathsf{T} \\ 0 & I \end{pmatrix}, \quad
   o = (−Σ_j e_j \ln x_j, 0 … 0)

(the edge-age coefficient ``w`` of a wearing quantity is left out: its marginal is the
sub-block). A Gaussian belief maps to ``N(T μ + o, T Σ T^\mathsf{T})``.

The *evidence* of the readings is the posterior less the prior it started from, in
information form (the product of Gaussians [1]_): ``J = P − P_0``, ``h = P m − P_0 m_0`` with
``P = (TΣT^\mathsf{T})^{-1}``. Where the learner's forgetting (the random walk ``τ``, a change's
discount) left less precision than the prior's in some direction, ``J`` is not positive
semidefinite there; that direction carries no evidence and is dropped (the projection on the
eigenvectors of positive eigenvalue), so a process that changed teaches the fleet only what
its readings since show.

References
----------
.. [1] Bishop, Pattern Recognition and Machine Learning (2006), §2.3.3 (Bayes' theorem for
   Gaussian variables; the information form).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from supervisor.rcb.posterior import Posterior

#: Eigenvalues of the evidence under this fraction of its largest are no evidence (round-off).
_RELATIVE_FLOOR = 1e-9


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


def transform(belief: Posterior, context: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """``T`` and ``o`` of ``belief`` (module docstring): ``θ = T β + o``."""
    n = len(belief.names)
    t = np.eye(n + 1)
    t[0, 1:] = -np.array(belief.center)
    offset = np.zeros(n + 1)
    offset[0] = -sum(e * math.log(context[name]) for name, e in belief.context_exponents.items())
    return t, offset


def in_tool_terms(belief: Posterior, context: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """The mean and covariance of ``θ`` under ``belief`` (``w`` marginalised out)."""
    n = len(belief.names)
    t, offset = transform(belief, context)
    mean = np.array(belief.mean[: n + 1])
    cov = np.array(belief.cov)[: n + 1, : n + 1]
    return t @ mean + offset, t @ cov @ t.T


def evidence(posterior: Posterior, prior: Posterior, context: Mapping[str, float]) -> Evidence:
    """The readings' information about ``θ``: ``posterior`` less the ``prior`` it started from."""
    if posterior.names != prior.names:
        raise ValueError(f"posterior over {posterior.names}, prior over {prior.names}")
    m, s = in_tool_terms(posterior, context)
    m0, s0 = in_tool_terms(prior, context)
    p, p0 = np.linalg.inv(s), np.linalg.inv(s0)
    j = 0.5 * ((p - p0) + (p - p0).T)
    h = p @ m - p0 @ m0
    values, vectors = np.linalg.eigh(j)
    keep = values > _RELATIVE_FLOOR * max(float(values.max()), 0.0)
    kept = vectors[:, keep]
    j = (kept * values[keep]) @ kept.T
    h = kept @ (kept.T @ h)
    return Evidence(posterior.names, j, h, posterior.observations)


def nothing(names: tuple[str, ...]) -> Evidence:
    """No evidence over ``θ = (ln K, names…)``."""
    n = len(names) + 1
    return Evidence(names, np.zeros((n, n)), np.zeros(n), 0)
