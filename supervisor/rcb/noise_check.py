r"""Whether a fleet's noise prior holds on this machine's measuring chain (issue 32).

A plan started from a fleet prior may also start its chains' noise scale ``λ`` from what the
fleet's chains showed (:mod:`supervisor.fleet.noise`): ``λ ~ InvGamma(a_f, b_f)`` instead of
the default :data:`~supervisor.rcb.noise.NOISE_PRIOR`, :data:`~supervisor.rcb.noise.
NOISE_RATE`, so that its first readings are counted at a noise near the one the fleet's
instruments showed instead of an upper quantile of a barely known one. A chain of another
kind (a worn stylus, a loose probe, a noisier drive) is not the fleet's: its readings would be
counted as worth more than they are, the cone would narrow past what they show, and the
monitor, measuring them against that noise, would read them as changes of the process.

The first part cannot show it: its innovations are the machine's offset, tens of times the
noise. So the fleet's prior is in force (:func:`in_force`) only once the chain's own readings
are worth :data:`IN_FORCE_READINGS` of pure noise, and before the monitor judges a report's
readings, they are weighed against both priors: each
reading's innovation ``e_i`` (its ``ln y`` less what the strategy expects on the high side,
:class:`~supervisor.rcb.monitor_state.Expected`) is ``N(0, m_i + λ u_i)``, ``m_i`` the
expectation's variance and ``u_i`` the noise's at the reported scale, and the chain's earlier
evidence (``n`` readings' worth, excess squares ``S``: its monitors' on the default prior)
is ``λ^{−n/2} e^{−S/2λ}``. The marginal of both over ``λ`` under an inverse-gamma prior [1]_,

.. math::

    p(e \mid a, b) = \int \mathrm{InvGamma}(λ; a, b)\, λ^{−n/2} e^{−S/2λ}
    \prod_i N(e_i; 0, m_i + λ u_i)\, dλ

(the conjugate closed form when every ``m_i = 0``, :func:`log_evidence`; here on a grid of
``ln λ``), gives the Bayes factor of the default over the fleet's. The fleet's is let go for
good, and the readings judged against the default's, when it beats the odds ``(1 − ε)/ε`` of
:data:`~supervisor.rcb.prior_check.OUTLIER_PROBABILITY` (the check of a machine's ``ln K``,
:mod:`supervisor.rcb.prior_check`), whether the chain is noisier than the fleet's prior says
or quieter. A quiet chain on a fleet whose instruments were noisy would otherwise count its
readings at the fleet's noise for good and learn slower than from the catalogue
(``closed_loop.py --fleet 4 --fleet-fault noise-scale:3``: 0.966 of the oracle after five
parts against the catalogue start's 0.969, 0.978 against 0.980 after ten); letting go only
returns the chain to the default, the catalogue start's own, so it is as safe as that. A
reading the monitor quarantines (a loose cable, an air cut) is not weighed: a glitch must not
throw away what the fleet learned. Letting a noisy chain go raises its scale and widens its
cones; letting a quiet one go gives it the default's scale and its own readings', which only
come down to what they show.

References
----------
.. [1] Gelman et al., Bayesian Data Analysis, 3rd ed., §2.6 (normal variance, conjugate
   inverse-gamma prior: the marginal of the sum of squares); Kass & Raftery (1995), "Bayes
   factors", JASA 90(430).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from supervisor.inputs.part_report import COVERAGE_FACTOR
from supervisor.rcb.judged import Judged
from supervisor.rcb.monitor_state import Monitor
from supervisor.rcb.noise import NoiseScale, pooled
from supervisor.rcb.prior_check import OUTLIER_PROBABILITY

#: ``ln`` of the odds a Bayes factor must beat to let a fleet's noise prior go.
LET_GO_LOG_ODDS = math.log((1.0 - OUTLIER_PROBABILITY) / OUTLIER_PROBABILITY)


def log_evidence(prior: NoiseScale, readings: float, excess: float) -> float:
    """``ln p(S | a, b)`` of ``readings`` readings with excess squares ``S`` (module docstring)."""
    a, b, half = prior.shape, prior.rate, 0.5 * readings
    return (
        a * math.log(b)
        - math.lgamma(a)
        + math.lgamma(a + half)
        - (a + half) * math.log(b + 0.5 * excess)
    )


#: A fleet's noise prior is in force once the chain's own evidence is worth this many readings
#: of pure noise: enough for the check to tell a chain 3 x noisier than it claims (``ln B``
#: 6.3 against a fleet's 25 % spread; at 3 readings, 3.7, and ``closed_loop.py --fleet 4
#: --fault noise-scale:3`` crossed 4 limits at parts 2-3 in 200 scenarios, at 6 none).
IN_FORCE_READINGS = 6.0


def in_force(prior: NoiseScale | None, evidence: Sequence[NoiseScale]) -> NoiseScale | None:
    """``prior`` once the chain's own ``evidence`` can tell its noise from the model, else None."""
    if prior is None:
        return None
    readings = sum(e.readings for e in evidence)
    return prior if readings >= IN_FORCE_READINGS else None


#: The grid of ``ln λ`` the marginal is integrated on: ``λ`` from 1/100 to 10⁴.
_LN_GRID = np.linspace(math.log(1e-2), math.log(1e4), 801)


@dataclass(frozen=True)
class Innovation:
    """A reading's innovation ``e`` and its variance ``m + λ u`` (module docstring)."""

    e: float
    model: float
    noise: float


def innovations(judged: Sequence[Judged]) -> dict[str, list[Innovation]]:
    """Per quantity, the innovations of the readings judged on the high side, none quarantined."""
    out: dict[str, list[Innovation]] = {}
    for j in judged:
        if j.expected is None or j.expected[1] is None or not j.watched.learns:
            continue
        high, m = j.expected[1], j.measurement
        if m.value <= 0:
            continue
        noise = (m.uncertainty / COVERAGE_FACTOR) / m.value
        model = (high.sd if high.estimate_sd is None else high.estimate_sd) ** 2
        e = math.log(m.value) - high.mean
        out.setdefault(j.quantity, []).append(Innovation(e, model, high.noise**2 + noise**2))
    return out


def log_marginal(prior: NoiseScale, own: NoiseScale, items: Sequence[Innovation]) -> float:
    """``ln p(e | a, b)`` with the chain's own earlier evidence ``own`` (module docstring)."""
    return _log_marginal(prior, _log_likelihood(own, items))


def _log_likelihood(own: NoiseScale, items: Sequence[Innovation]) -> np.ndarray:
    """``ln`` of the readings' likelihood at every ``λ`` of the grid."""
    lam = np.exp(_LN_GRID)
    out = -0.5 * own.readings * _LN_GRID - 0.5 * own.excess / lam
    if items:
        e2 = np.array([i.e**2 for i in items])[:, None]
        variance = np.array([i.model for i in items])[:, None] + np.outer(
            [i.noise for i in items], lam
        )
        out = out - 0.5 * np.sum(np.log(2 * math.pi * variance) + e2 / variance, axis=0)
    return out


def _log_marginal(prior: NoiseScale, log_likelihood: np.ndarray) -> float:
    """The likelihood integrated over ``InvGamma(λ; a, b)`` on the grid (``λ dλ = d ln λ``)."""
    a, b = prior.shape, prior.rate
    log_f = a * math.log(b) - math.lgamma(a) - a * _LN_GRID - b / np.exp(_LN_GRID)
    log_f = log_f + log_likelihood
    top = float(np.max(log_f))
    return top + math.log(float(np.trapezoid(np.exp(log_f - top), _LN_GRID)))


def rejects(prior: NoiseScale, own: NoiseScale, items: Sequence[Innovation]) -> bool:
    """Whether the chain's evidence lets the fleet's ``prior`` go (module docstring).

    ``own``: its earlier evidence, on the default prior; ``items``: this report's innovations.
    """
    if own.readings + len(items) <= 0.0:
        return False  # no reading yet
    log_likelihood = _log_likelihood(own, items)
    log_bayes = _log_marginal(NoiseScale(), log_likelihood) - _log_marginal(prior, log_likelihood)
    return log_bayes > LET_GO_LOG_ODDS


def kept(
    priors: Mapping[str, NoiseScale],
    monitors: Mapping[tuple[str, str], Monitor],
    judged: Sequence[Judged],
) -> dict[str, NoiseScale]:
    """The fleet's noise priors per quantity that the chains' evidence keeps.

    ``monitors``: the plan's, whose chains' earlier evidence (on the default prior) is
    weighed; ``judged``: the report's readings as the monitor judged them against the fleet's
    prior. A plan with no fleet noise prior (most) pays nothing.
    """
    if not priors:
        return {}
    own, found = chains_of(monitors), innovations(judged)
    return {
        q: p
        for q, p in priors.items()
        if not rejects(p, own.get(q, NoiseScale()), found.get(q, []))
    }


def chains_of(
    monitors: Mapping[tuple[str, str], Monitor], priors: Mapping[str, NoiseScale] | None = None
) -> dict[str, NoiseScale]:
    """Per quantity, the noise scale of the chain that reads it in every operation.

    :func:`supervisor.rcb.noise.pooled`: one instrument measures a quantity in every operation
    of a plan and misreports its ``u`` by one factor. ``priors``: a chain's prior where it is
    a fleet's, once in force (:func:`in_force`); else the default.
    """
    priors = priors or {}
    by_quantity: dict[str, list[NoiseScale]] = {q: [] for q in priors}
    for (_, quantity), monitor in monitors.items():
        by_quantity.setdefault(quantity, []).append(monitor.chain_noise)
    return {q: pooled(group, in_force(priors.get(q), group)) for q, group in by_quantity.items()}
