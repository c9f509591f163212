r"""How far apart the fleet's machines (and a machine's operations) are: their spreads' estimates.

The estimates of :mod:`.hierarchy`'s spreads ``σ_b`` and ``σ_o`` (its module docstring: "The
spread", "The comparison", "The operations' spread"): each machine's (or operation's) ``ln Y``
where the readings pin it best (:func:`best_determined`), from its evidence with the
catalogue's exponents but not its ``ln K`` (:func:`intercept_free`), compared by
DerSimonian and Laird's moment estimate (:func:`dersimonian_laird`) and pooled with a
default (:func:`pooled`), with its lower credible bound (:func:`lower_bound`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from supervisor.fleet.evidence import Evidence
from supervisor.fleet.hierarchy import SPREAD_WEIGHT


def best_determined(
    machines: Sequence[Evidence],
    prior_information: np.ndarray,
    exponents: int,
    centre: Sequence[float],
) -> np.ndarray:
    """``φ = (1, x, 0 …)`` where the machines' ``ln Y`` is best known (module docstring).

    ``x`` (the ``exponents`` log-inputs) minimises ``Σ_m φ^T C_m φ``, ``C_m`` machine ``m``'s
    covariance with the prior's exponents (:func:`intercept_free`): ``x = −(Σ C_xx)^{-1} Σ
    C_x0``; a quantity's ``ω`` (if any) at 0, a new edge. With no machine (none with a
    reading), ``x`` is ``centre``, the new operation's log-centre: the spread is then the
    default at any point, and the exponents pivot where it cuts.
    """
    reference = np.zeros(len(prior_information))
    reference[0] = 1.0
    if exponents == 0:
        return reference
    free = intercept_free(prior_information)
    told = _told(machines, free)
    if not told:
        reference[1 : exponents + 1] = centre
        return reference
    covs = np.linalg.inv(free + np.array([m.information for m in told]))
    block = covs[:, 1 : exponents + 1, 1 : exponents + 1].sum(axis=0)
    cross = covs[:, 1 : exponents + 1, 0].sum(axis=0)
    reference[1 : exponents + 1] = -np.linalg.solve(block, cross)
    return reference


def between_estimate(
    machines: Sequence[Evidence],
    prior_mean: np.ndarray,
    prior_information: np.ndarray,
    reference: np.ndarray,
) -> tuple[float, int]:
    """``(τ̂², M − 1)``: the machines' DerSimonian-Laird spread at ``reference`` (module doc)."""
    return dersimonian_laird(_at_each(reference, machines, prior_mean, prior_information))


def operation_estimates(
    machines: Sequence[Sequence[Evidence]],
    prior_mean: np.ndarray,
    prior_information: np.ndarray,
    exponents: int,
) -> list[tuple[float, int]]:
    """Per machine of two operations or more, their DerSimonian-Laird ``(τ̂², dof)``.

    The operations' ``ln Y`` are compared where they pin it best (:func:`best_determined`).
    """
    found = []
    for ops in machines:
        if len(ops) < 2:
            continue
        centre = (0.0,) * exponents  # unused: two or more operations fix the point
        reference = best_determined(ops, prior_information, exponents, centre)
        found.append(dersimonian_laird(_at_each(reference, ops, prior_mean, prior_information)))
    return found


def pooled(default: float, weight: float, found: Sequence[tuple[float, int]]) -> float:
    """``√((ν_0 σ_0² + Σ dof τ̂²)/(ν_0 + Σ dof))`` of estimates ``(τ̂², dof)`` (module doc)."""
    dof = sum(d for _, d in found)
    tau2 = sum(d * t2 for t2, d in found)
    return math.sqrt((weight * default**2 + tau2) / (weight + dof))


def lower_bound(sigma: float, dof: float, probability: float = 0.95) -> float:
    """``σ``'s lower credible bound: the true spread is above it with ``probability``.

    ``σ`` as :func:`pooled` gives it, the scale of the scaled inverse-χ² posterior of ``σ²`` on
    ``dof`` (``ν_0 + Σ dof``) degrees of freedom (Gelman et al., BDA 3rd ed., §2.6):
    ``σ √(ν / χ²_{probability, ν})``, the χ² quantile as ``2 P^{-1}(ν/2, probability)``; 0
    under 1 degree of freedom.
    """
    # imported here: scipy takes 0.2-0.5 s to import (supervisor/fleet/noise.py)
    from scipy import special

    if dof < 1.0:  # too little evidence for a bound (under 1 the quantile's tail passes σ)
        return 0.0
    return sigma * math.sqrt(dof / (2.0 * float(special.gammaincinv(dof / 2.0, probability))))


def _at_each(
    reference: np.ndarray,
    seen: Sequence[Evidence],
    prior_mean: np.ndarray,
    prior_information: np.ndarray,
) -> list[tuple[float, float]]:
    """Per evidence of ``seen``, ``(y, v)``: ``ln Y`` at ``reference``, and its variance.

    From that evidence alone about ``ln K``, with the prior's exponents (module docstring,
    "the comparison"): the prior's information on ``ln K`` given the exponents is left out,
    so each ``y`` is not pulled toward the catalogue's and their differences are the
    readings'. Evidence that pins its ``ln Y`` no better than :data:`_LEAST` (a plan with no
    reading since its start or its last change) is left out: it says nothing of the spread,
    and would count a degree of freedom. Stacked, at once.
    """
    free = intercept_free(prior_information)
    told = _told(seen, free)
    if not told:
        return []
    cov = np.linalg.inv(free + np.array([s.information for s in told]))
    vector = free @ prior_mean + np.array([s.vector for s in told])
    mean = (cov @ vector[..., np.newaxis])[..., 0]
    values = mean @ reference
    variances = (reference @ cov) @ reference
    return [(float(y), float(v)) for y, v in zip(values, variances, strict=True)]


#: The least information about ``ln K`` given the exponents for evidence to be compared
#: [1/ln²]: ``ln Y`` known to 1 in ``ln`` (a factor ``e``), where one reading of a 10 %
#: instrument gives 100.
_LEAST = 1.0


def intercept_free(prior_information: np.ndarray) -> np.ndarray:
    """The prior's information about the exponents (and ``ω``) alone, none about ``ln K``.

    ``θ``'s exponents' marginal is the prior covariance's block without ``ln K``; its inverse,
    bordered by zeros, is a prior flat in ``ln K`` given the exponents.
    """
    free = np.zeros_like(prior_information)
    if len(prior_information) > 1:
        cov = np.linalg.inv(prior_information)
        free[1:, 1:] = np.linalg.inv(cov[1:, 1:])
    return free


def _told(seen: Sequence[Evidence], free: np.ndarray) -> list[Evidence]:
    """The evidence of ``seen`` that pins ``ln Y`` with the prior ``free`` (:func:`_at_each`)."""
    return [s for s in seen if _intercept_information(free + s.information) >= _LEAST]


def _intercept_information(information: np.ndarray) -> float:
    """``information``'s about ``ln K`` given the rest: its Schur complement at ``[0, 0]``."""
    rest = information[1:, 1:]
    if not len(rest):
        return float(information[0, 0])
    cross = information[1:, 0]
    return float(information[0, 0] - cross @ np.linalg.solve(rest, cross))


def dersimonian_laird(estimates: Sequence[tuple[float, float]]) -> tuple[float, int]:
    """``(τ̂², k − 1)`` of ``k`` estimates ``(y, v)``: their moment estimate of the spread.

    DerSimonian & Laird (1986), :mod:`.hierarchy`'s reference [2].
    """
    if len(estimates) < 2:
        return 0.0, 0
    weights = [1.0 / v for _, v in estimates]
    total = sum(weights)
    centre = sum(w * y for w, (y, _) in zip(weights, estimates, strict=True)) / total
    q = sum(w * (y - centre) ** 2 for w, (y, _) in zip(weights, estimates, strict=True))
    scale = total - sum(w * w for w in weights) / total
    tau2 = max(0.0, (q - (len(estimates) - 1)) / scale) if scale > 0 else 0.0
    return tau2, len(estimates) - 1


def pooled_spread(
    estimates: Sequence[tuple[float, float]], default: float, weight: float = SPREAD_WEIGHT
) -> float:
    """``σ_b`` of estimates ``(y_m, v_m)``: the default pooled with their ``τ̂²`` (module doc)."""
    return pooled(default, weight, [dersimonian_laird(estimates)])
