r"""The noise scale of a measuring chain: how much noisier its readings are than their ``u``.

The reported ``u`` is a prior on the noise, not its value (DESIGN.md, RCB: "The shop floor
misbehaves"). The variance of a reading is ``λ (u/k)²``, ``λ ~ InvGamma(a, b)``;
:func:`supervisor.rcb.monitor.watch` updates ``a`` and ``b`` from each reading's innovation.
Three scales are read off the belief, never under 1 (a chain quieter than it claims is not
trusted to be):

- ``ŝ = √max(b/a, 1)`` (1 before any reading) of the operation's own evidence, the band law's
  and the alarm's: ``u`` becomes ``ŝ u`` there, with ``ŝ`` as it stood before the reading; the
  paper's law and its golden numbers are unchanged while the readings agree with their ``u``
  (pooled, one operation's model error counted as the chain's noise blinds every alarm);
- ``√max(λ_q, 1)``, ``λ_q`` the upper :data:`PRUDENT_QUANTILE` quantile of the chain's ``λ``
  (2.11 before any reading), ``learn``'s likelihood and the scale its earlier readings are
  counted at (:func:`supervisor.rcb.learning.rescaled`, in both directions): a posterior is
  not narrowed by two or three readings of a chain whose noise is not yet known, and the
  scale comes down as fast as the chain shows it is quiet; the band law's alarm near the
  limit (:mod:`supervisor.rcb.law`);
- the same at the upper :data:`BOUND_QUANTILE` quantile, ``Φ(2)`` (3.15 before any reading):
  the band law's bound on a truth over its prediction, or after a change (the ``k = 2`` of
  the paper's ``y + u`` while the noise is not yet known).

The chain's evidence forgets: each reading keeps ``1 − 1/M`` of the evidence before it
(:data:`NOISE_MEMORY`, ``M`` = 20 readings per operation; variance discounting, West &
Harrison §10.8 [2]_). Without it a chain that turned 3x noisier after 500 quiet parts was
still read at a scale of about 1.3 sixty readings later, and ``learn`` counted its readings
three times too precise: 417 crossings in 30 scenarios x 1000 parts; with ``M`` = 50, 35;
with 20, 6 (docs/benchmarks.md, *A year of parts*). Its cost is the quantile: a quiet chain
stays at a prudent scale of about 1.15-1.3 instead of coming down to 1. A sudden change is
also tested for (:mod:`supervisor.rcb.noise_watch`, a CUSUM per chain that cuts the old
evidence back): 2 crossings there, from 6.

``learn``'s belief is the *chain's*: one instrument (the dynamometer, the profilometer, the spindle
drive) reads a quantity in every operation of a plan and misreports its ``u`` by one factor
in each. Each operation's monitor keeps its own evidence and :func:`pooled` adds them up: six
operations teach the chain's noise six times as fast as one.

Measured on ``benchmarks/closed_loop.py`` (``learn``; avoidable crossings at noise-scale 3,
the true noise 3 x the reported ``u`` / MRR/oracle after 10 clean parts; 200 scenarios x 30
parts): per operation, the posterior mean ``√(b/(a − 1))`` 45 / 0.981, the 0.90 quantile
4 / 0.979; pooled over the chain, the mean 10 / 0.982, the quantile 0.90 1 / 0.981, 0.93
1 / 0.981, 0.95 0 / 0.980, 0.97 0 / 0.979. 1000 scenarios: 0.95 0 / 0.9797 (under the
0.98 target), 0.93 (chosen) 1 / 0.980 (206 / 0.981 before).

References
----------
.. [1] Gelman et al., Bayesian Data Analysis, 3rd ed., §2.6 (normal variance, conjugate
   inverse-gamma prior) and §14.8.
.. [2] West & Harrison, Bayesian Forecasting and Dynamic Models, 2nd ed. (1997), §10.8:
   variance discounting, an observational variance that may change over time.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

#: ``a`` and ``b`` of the noise scale's inverse-gamma prior: ``b/a < 1`` (the law starts at the
#: reported ``u``), three half-readings' weight; its upper 7 % quantile, ``λ = 4.46``, is what
#: ``learn`` starts at (a chain 2.11 x noisier than it claims).
NOISE_PRIOR = 1.5
NOISE_RATE = 1.0
#: The chain's evidence of its noise is worth at most this many readings per operation: each
#: reading keeps ``1 − 1/M`` of the evidence before it (variance discounting, West & Harrison,
#: *Bayesian Forecasting and Dynamic Models*, 2nd ed., §10.8), so a chain that turns noisier
#: after hundreds of quiet parts is believed within tens of parts (module docstring).
NOISE_MEMORY = 20.0
#: ``learn`` counts readings at this upper quantile of the chain's noise scale (module docstring).
PRUDENT_QUANTILE = 0.93
#: The band law bounds a truth over its prediction, or after a change, at this upper quantile:
#: ``Φ(2)``, the ``k = 2`` of the paper's ``y + u`` (:mod:`supervisor.rcb.law`).
BOUND_QUANTILE = 0.9772498680518208
_TAILS = np.array([1.0 - PRUDENT_QUANTILE, 1.0 - BOUND_QUANTILE])


@dataclass(frozen=True)
class NoiseScale:
    """The inverse-gamma belief ``λ ~ InvGamma(a, b)`` on the noise variance's scale."""

    shape: float = NOISE_PRIOR
    rate: float = NOISE_RATE

    @classmethod
    def of_evidence(cls, readings: float, excess: float) -> NoiseScale:
        """The default prior and ``readings`` readings' worth of excess squares ``excess``.

        The inverse of :attr:`readings` and :attr:`excess`.
        """
        return cls(NOISE_PRIOR + 0.5 * readings, NOISE_RATE + 0.5 * excess)

    @property
    def readings(self) -> float:
        """``2(a − a₀)``: the readings' worth of evidence beyond the default prior."""
        return 2.0 * (self.shape - NOISE_PRIOR)

    @property
    def excess(self) -> float:
        """``2(b − b₀)``: the sum of those readings' excess squares (in ``u²``)."""
        return 2.0 * (self.rate - NOISE_RATE)

    @property
    def scale(self) -> float:
        """``ŝ = √max(b/a, 1)``: the noise in force as a multiple of the reported one."""
        return math.sqrt(max(self.rate / self.shape, 1.0))

    @property
    def prudent_scale(self) -> float:
        """``√max(λ_q, 1)``, ``λ_q`` the upper :data:`PRUDENT_QUANTILE` quantile of ``λ``."""
        return self.scales()[0]

    @property
    def bound_scale(self) -> float:
        """``√max(λ_q, 1)``, ``λ_q`` the upper :data:`BOUND_QUANTILE` quantile of ``λ``."""
        return self.scales()[1]

    def scales(self) -> tuple[float, float]:
        """``(prudent, bound)`` scales: ``√max(λ_q, 1)`` at each quantile, in one call.

        ``P(λ > λ_q) = 1 − q`` is ``P(G < b/λ_q) = 1 − q`` for ``G ~ Gamma(a, 1)``, so ``λ_q =
        b / P⁻¹(a, 1 − q)`` (Gelman et al. §2.6; ``scipy.special.gammaincinv``).
        """
        # imported here: scipy.special takes 0.3-1 s to import, which every reader of a plan's
        # state (rcb report, the web view) paid at start without ever calling it
        from scipy.special import gammaincinv

        tails = gammaincinv(self.shape, _TAILS)
        prudent, bound = (math.sqrt(max(self.rate / float(t), 1.0)) for t in tails)
        return prudent, bound


def pooled(beliefs: Iterable[NoiseScale], prior: NoiseScale | None = None) -> NoiseScale:
    """The chain's belief: the prior and each operation's evidence (``a − a₀``, ``b − b₀``).

    ``prior``: the chain's prior where it is not :data:`NOISE_PRIOR`, :data:`NOISE_RATE` (the
    fleet's, :mod:`supervisor.fleet.noise`).
    """
    shape, rate = (NOISE_PRIOR, NOISE_RATE) if prior is None else (prior.shape, prior.rate)
    for belief in beliefs:
        shape += belief.shape - NOISE_PRIOR
        rate += belief.rate - NOISE_RATE
    return NoiseScale(shape, rate)
