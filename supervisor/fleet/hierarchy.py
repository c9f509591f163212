r"""The fleet's belief about a tool's model: shared exponents, a ``ln K`` offset per machine.

A tool cuts a material by one law on every machine, up to the machine: each machine ``m``
(its spindle, its rigidity, its coolant) has an offset ``δ_m`` in ``ln K``, drawn from a
between-machine spread that is itself learned (a normal hierarchical model, Gelman et al.
[1]_ §5.4-5.5):

.. math:: θ_m = θ + δ_m e_0, \qquad δ_m \sim N(0, σ_b^2)

**The fleet's belief.** Machine ``m``'s evidence ``(J_m, h_m)`` (:mod:`.evidence`, summed
over its operations on the tool) is about ``θ_m``; integrating ``δ_m`` out gives its evidence
about ``θ`` (a rank-one update, Sherman-Morrison):

.. math:: J'_m = J_m − c\, J_m e_0 e_0^\mathsf{T} J_m, \quad
   h'_m = h_m − c\, (e_0^\mathsf{T} h_m) J_m e_0, \quad c = (σ_b^{-2} + e_0^\mathsf{T} J_m e_0)^{-1}

so a machine, however many parts it made, says at most ``σ_b`` about the fleet's ``ln K``,
while its exponents count in full. With the catalogue prior ``(P_0, m_0)``:
``P = P_0 + Σ J'_m``, ``μ = P^{-1}(P_0 m_0 + Σ h'_m)``. A new machine's ``θ`` is
``N(μ, P^{-1} + σ_b^2 e_0 e_0^\mathsf{T})``.

**The spread.** Each machine's own posterior (the catalogue prior and its evidence alone)
gives its ``ln Y`` at a reference point, ``y_m ± √v_m``. The point is where the machines'
readings pin ``ln Y`` best, ``φ = (1, x, 0)`` minimising ``Σ_m φ^\mathsf{T} C_m φ``
(:func:`best_determined`): at the centre of the bounds, where machines that learned near
their optima never cut, every ``v_m`` holds the exponents' uncertainty (10 % and more), the
machines' differences drown in it and the estimate is 0 whatever they are. DerSimonian and
Laird's moment estimate [2]_ of the spread between them, ``τ̂²``, is pooled with a default
``σ_0`` held as ``ν_0`` machines' worth of evidence (the scaled inverse-χ² prior of a
normal variance, [1]_ §2.6):

.. math:: σ_b^2 = \frac{ν_0 σ_0^2 + (M − 1) τ̂^2}{ν_0 + M − 1}

never zero, the default until machines disagree, and the machines' own spread as they
accumulate (:data:`DEFAULT_SPREAD`, :data:`SPREAD_WEIGHT`: ``benchmarks/closed_loop.py
--fleet``).

References
----------
.. [1] Gelman et al., Bayesian Data Analysis, 3rd ed.: §2.6 (scaled inverse-χ² prior of a
   normal variance), §5.4-5.5 (the hierarchical normal model; the group means' posterior).
.. [2] DerSimonian & Laird (1986), "Meta-analysis in clinical trials", Controlled Clinical
   Trials 7(3), 177-188.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from supervisor.fleet.evidence import Evidence

#: ``σ_0``: the default between-machine spread of ``ln K`` [-], 5 %: the machines' share of a
#: tool's scatter (benchmarks/closed_loop.py --fleet; the module docstring).
DEFAULT_SPREAD = 0.05
#: ``ν_0``: the default spread counts as this many machines' evidence.
SPREAD_WEIGHT = 2.0


@dataclass(frozen=True)
class FleetBelief:
    """``θ ~ N(mean, cov)`` of a new machine, the spread ``σ_b`` and what it came from."""

    mean: np.ndarray
    cov: np.ndarray
    spread: float
    machines: int
    readings: int


def marginal(evidence: Evidence, spread: float) -> tuple[np.ndarray, np.ndarray]:
    """``(J', h')``: a machine's evidence about the fleet's ``θ`` (module docstring)."""
    j, h = evidence.information, evidence.vector
    j0 = j[:, 0]
    c = 1.0 / (spread**-2 + j[0, 0])
    return j - c * np.outer(j0, j0), h - c * h[0] * j0


def best_determined(
    machines: Sequence[Evidence], prior_information: np.ndarray, exponents: int
) -> np.ndarray:
    """``φ = (1, x, 0 …)`` where the machines' ``ln Y`` is best known (module docstring).

    ``x`` (the ``exponents`` log-inputs) minimises ``Σ_m φ^T C_m φ``, ``C_m`` machine ``m``'s
    covariance with the prior: ``x = −(Σ C_xx)^{-1} Σ C_x0``; a quantity's ``ω`` (if any) at
    0, a new edge. With no machine, ``x = 0`` (the spread is then the default, at any point).
    """
    reference = np.zeros(len(prior_information))
    reference[0] = 1.0
    if not machines or exponents == 0:
        return reference
    covs = [np.linalg.inv(prior_information + m.information) for m in machines]
    block = sum((c[1 : exponents + 1, 1 : exponents + 1] for c in covs), np.zeros((exponents,) * 2))
    cross = sum((c[1 : exponents + 1, 0] for c in covs), np.zeros(exponents))
    reference[1 : exponents + 1] = -np.linalg.solve(block, cross)
    return reference


def between_spread(
    machines: Sequence[Evidence],
    prior_mean: np.ndarray,
    prior_information: np.ndarray,
    reference: np.ndarray,
    default: float = DEFAULT_SPREAD,
    weight: float = SPREAD_WEIGHT,
) -> float:
    """``σ_b``: the default pooled with the machines' DerSimonian-Laird spread (module docstring).

    ``reference``: ``φ`` of the point the machines' ``ln Y`` are compared at.
    """
    estimates = []
    for m in machines:
        cov = np.linalg.inv(prior_information + m.information)
        mean = cov @ (prior_information @ prior_mean + m.vector)
        estimates.append((float(reference @ mean), float(reference @ cov @ reference)))
    return pooled_spread(estimates, default, weight)


def pooled_spread(
    estimates: Sequence[tuple[float, float]], default: float, weight: float = SPREAD_WEIGHT
) -> float:
    """``σ_b`` of estimates ``(y_m, v_m)``: the default pooled with their ``τ̂²`` (module doc)."""
    if len(estimates) < 2:
        return default
    weights = [1.0 / v for _, v in estimates]
    total = sum(weights)
    centre = sum(w * y for w, (y, _) in zip(weights, estimates, strict=True)) / total
    q = sum(w * (y - centre) ** 2 for w, (y, _) in zip(weights, estimates, strict=True))
    scale = total - sum(w * w for w in weights) / total
    tau2 = max(0.0, (q - (len(estimates) - 1)) / scale) if scale > 0 else 0.0
    dof = len(estimates) - 1
    return math.sqrt((weight * default**2 + dof * tau2) / (weight + dof))


def fleet_belief(
    machines: Sequence[Evidence],
    prior_mean: np.ndarray,
    prior_cov: np.ndarray,
    reference: np.ndarray,
    default: float = DEFAULT_SPREAD,
    weight: float = SPREAD_WEIGHT,
) -> FleetBelief:
    """A new machine's ``θ`` from the machines' evidence and the catalogue prior."""
    p0 = np.linalg.inv(prior_cov)
    spread = between_spread(machines, prior_mean, p0, reference, default, weight)
    information, vector = p0.copy(), p0 @ prior_mean
    for m in machines:
        j, h = marginal(m, spread)
        information, vector = information + j, vector + h
    cov = np.linalg.inv(information)
    cov = 0.5 * (cov + cov.T)
    mean = cov @ vector
    cov[0, 0] += spread**2
    return FleetBelief(mean, cov, spread, len(machines), sum(m.readings for m in machines))
