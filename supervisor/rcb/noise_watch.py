r"""Whether a measuring chain turned noisier than its evidence says: a CUSUM per chain.

The chain's evidence of its noise forgets (:data:`supervisor.rcb.noise.NOISE_MEMORY`), so a
chain that turns noisier is believed within tens of readings; while the evidence turns over,
``learn`` counts the new readings too precise (6 crossings in 30 scenarios x 1000 parts of
``noise-step:500:3``, docs/benchmarks.md, *A year of parts*). A sudden change is told sooner
by a test of it (Page 1954; Basseville & Nikiforov, *Detection of Abrupt Changes*, 1993,
§2.2): with ``x`` a reading's squared noise in units of the chain's believed variance
(``χ²₁`` while the belief holds), the log-likelihood ratio of a variance ``K`` times larger is

.. math:: \ell(x) = \tfrac12 (1 - 1/K)\, x - \tfrac12 \ln K

weighted by the share of the reading's innovation that is noise. Each operation's monitor
keeps its reading's ``ℓ`` (:func:`supervisor.rcb.monitor.watch`); after a part, the chain's
CUSUM ``S ← max(0, S + Σ ℓ)`` sums its operations' (:func:`watched`). Past :data:`ALARM_H`
every operation's evidence of the chain is cut to :data:`INTERVENTION` of itself (its mean
kept: an intervention, West & Harrison §11.2), so the next readings decide.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, MutableMapping
from dataclasses import replace

from supervisor.rcb.monitor_state import Monitor
from supervisor.rcb.noise import NOISE_PRIOR

#: The variance ratio the test looks for.
ALARM_K = 2.0
#: The CUSUM's threshold: a steady chain raises it once in about 50 000 readings, a chain
#: three times noisier (nine in variance) within about 21 (simulated, ``χ²₁`` readings).
ALARM_H = 8.0
#: The share of a chain's evidence an alarm keeps.
INTERVENTION = 0.25
#: A chain is watched once its evidence is worth this many readings in an operation (before,
#: it is still learning its noise from the prior's).
WATCHED_FROM = 5.0


def llr(x: float) -> float:
    """``ℓ(x)``: the log-likelihood ratio of a variance :data:`ALARM_K` times larger."""
    return 0.5 * (1.0 - 1.0 / ALARM_K) * x - 0.5 * math.log(ALARM_K)


def watched_monitor(monitor: Monitor) -> bool:
    """Whether the monitor's evidence of its chain is enough to watch."""
    return monitor.chain_shape - NOISE_PRIOR >= 0.5 * WATCHED_FROM


def watched(monitors: MutableMapping[tuple[str, str], Monitor], read: Iterable[str]) -> None:
    """After a part: each chain of ``read`` (a quantity) with its CUSUM, cut back on an alarm."""
    for quantity in sorted(set(read)):
        keys = [key for key in monitors if key[1] == quantity]
        before = max(monitors[k].chain_alarm for k in keys)  # each holds it; never under 0
        chain = max(0.0, before + math.fsum(monitors[k].noise_llr for k in keys))
        alarm = chain > ALARM_H
        for key in keys:
            monitor = monitors[key]
            if alarm:
                shape, rate = monitor.chain_kept(INTERVENTION)
                monitor = replace(monitor, chain_shape=shape, chain_rate=rate)
            monitors[key] = replace(monitor, noise_llr=0.0, chain_alarm=0.0 if alarm else chain)
