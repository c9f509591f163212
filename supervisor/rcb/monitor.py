r"""What RCB watches in the readings of one quantity, whatever the strategy.

The band law and the strategies learn from readings; a shop floor sends some that must not be
learned from as they stand (DESIGN.md, RCB: "The shop floor misbehaves"). Per operation and
quantity a :class:`Monitor` keeps what that takes, and :func:`watch` classifies each reading
before anything is learned from it, against what the strategy expects of it
(:meth:`supervisor.rcb.strategies.Strategy.expects`: a mean and a spread of ``ln y``, one for
each side). With ``s`` the expectation's spread, ``s_n = ŝ (u/k)/y`` the reading's noise at the
*measured* scale ``ŝ`` (below) and ``e = ln y − m`` the innovation,

.. math:: r = e \,/\, \sqrt{s^2 + s_n^2}

- ``r < −``:data:`LOW_SIGMA` on the low side, or under half the expectation's lower ``2σ`` edge
  (a wide prior, before the first reading, makes ``r`` small): *too good to be true* (a loose
  cable, an air cut, a broken insert that no longer cuts: a reading at 10 % of the truth is ``e
  = −2.3``). The reading is quarantined (note ``implausible_low``): no band, posterior, wear
  rise or noise scale learns from it. It is learned from once the next reading confirms it:
  consistent with it within :data:`CONFIRM_SIGMA` of their joint noise (the setpoint's change
  taken out with the model's exponents, their prior spread counted as noise, as
  :mod:`supervisor.rcb.wear` does); the process has then moved down, and the pair is a
  ``regime_change``. A reading that does not confirm it drops it (a glitch).
- ``r > ``:data:`CHANGE_SIGMA` on the high side: *evidence against the model*, a process that
  has changed (a harder batch, another insert supplier). The old regime's evidence is
  discounted by a random-walk step of the intercept sized to explain the innovation,
  ``q = e² − (s² + s_n²)`` (moment matching, the adaptive fading of a Kalman filter [3]_), so
  the reading is learned at once instead of averaged in at ``1/n``; the decision says
  ``regime_change``. A shift too small for one reading is found by the upper CUSUM of ``r``
  (:data:`CUSUM_K`, :data:`CUSUM_H`; Page 1954 [4]_), which discounts the mean shift of the
  readings since it last stood at 0.

The noise scale: the reported ``u`` is a prior on the noise, not its value. The variance of a
reading is ``λ (u/k)²`` with ``λ ~ InvGamma(a, b)`` (:mod:`supervisor.rcb.noise`: its prior,
the scales read off it, one belief per measuring chain). Each reading not quarantined
updates it from its innovation on the high side, ``E e² = s² + λ (s_c² + s_n²)`` (``s_c``:
the noise of the chain's last reading, for ``ivester`` and ``bayes`` whose expectation is
that reading moved to the setpoint: then ``e`` is a successive difference [1]_, counted only
when the setpoint moved less than the pair's noise explains), by the share of the
innovation's variance that is noise, ``ω = λ̂ v / (s² + λ̂ v)`` with ``v = s_c² + s_n²``:

.. math:: a ← a + ω/2, \qquad b ← b + \frac{ω}{2} \frac{(\min(e^2, c^2 σ_e^2) − s^2)^+}{v}

(a conjugate update [2]_ weighted by how much the reading says about the noise; ``c`` the
change threshold, so one change counts as a reading at the alarm's edge).

References
----------
.. [1] von Neumann, Kent, Bellinson & Hart (1941), "The mean square successive difference",
   Ann. Math. Statist. 12(2), 153-162.
.. [2] Gelman et al., Bayesian Data Analysis, 3rd ed., §2.6 (normal variance, conjugate
   inverse-gamma prior).
.. [3] Xia, Rao, Ying & Shen (1994), "Adaptive fading Kalman filter with an application",
   Automatica 30(8), 1333-1338; Mehra (1972), "Approaches to adaptive filtering", IEEE Trans.
   Automatic Control 17(5) (innovation-based adaptation).
.. [4] Page (1954), "Continuous inspection schemes", Biometrika 41(1/2), 100-115; Montgomery,
   Introduction to Statistical Quality Control, the tabular CUSUM.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Literal

from supervisor.inputs.part_report import COVERAGE_FACTOR, Measurement
from supervisor.rcb import noise_watch
from supervisor.rcb.monitor_state import Expected, Monitor, Reading
from supervisor.rcb.noise import NOISE_MEMORY
from supervisor.rcb.wear import setpoint_shift

#: A reading this many σ under what the strategy expects is quarantined (``implausible_low``).
LOW_SIGMA = 6.0
#: A reading this many σ over what the strategy expects is a change of the process.
CHANGE_SIGMA = 4.0
#: The upper CUSUM of the standardised innovations, ``S ← max(0, S + r − k)``, raises a change
#: when ``S > h`` (Page 1954; Montgomery, Statistical Quality Control, the tabular CUSUM):
#: ``k = 0.5`` looks for a shift of one σ; ``h = 6`` runs about 2 600 in-control readings
#: between false alarms (Siegmund's approximation). ``h = 5`` (about 900) backed a ``learn``
#: setpoint off on a truth 0.95 x the model (tests/test_learn.py); ``h = 8`` (about 19 000)
#: let a +12 % step under 3x noise cross on 655 parts in 60 scenarios, against 421 at 6.
CUSUM_K = 0.5
CUSUM_H = 6.0
#: While the CUSUM stands above this, the readings drift off a model's expectation (``learn``'s
#: posterior predictive) and teach the noise scale nothing: a shift counted as noise inflates
#: ``ŝ`` and blinds the alarm that should find it (all five faults, 200 scenarios: 1104
#: avoidable crossings without the gate, 950 at 3, 799 at 2, 683 at 1; but at 1 a chain 3x
#: noisier than it claims looked like a drift before its noise was known: noise-scale 3, 1000
#: scenarios, 8 avoidable crossings at 1, 1 at 2 as without the gate). A successive difference
#: (``ivester``, ``bayes``) carries no model error and is not gated (the gate took 74 to 116).
DRIFTING = 2.0
#: A quarantined reading is confirmed by the next one within this many σ of their joint noise.
CONFIRM_SIGMA = 3.0
#: A quarantined reading more than this (in ``ln``: a factor 2) under what was expected is
#: never confirmed: no change of a process halves it; a sensor or a tool does.
CONFIRMABLE = math.log(2.0)
#: Each reading keeps this share of the chain's earlier noise evidence: ``1 − 1/M``, a memory
#: of ``M`` = :data:`~supervisor.rcb.noise.NOISE_MEMORY` readings per operation.
NOISE_KEEP = 1.0 - 1.0 / NOISE_MEMORY
Verdict = Literal["accept", "quarantine", "confirm", "change"]


@dataclass(frozen=True)
class Watched:
    """What :func:`watch` made of a reading.

    ``forget``: the variance ``q`` the intercept's belief takes before it learns (0 unless a
    change or a confirmed quarantine); ``held``: the quarantined reading a ``confirm`` learns
    from too; ``sigma``: ``r`` of the reading on the side that decided (0 for ``accept``);
    ``innovation``: ``(e, v)`` on the high side when the reading was judged there (None: it
    was not), which :mod:`supervisor.rcb.common_cause` pools over the operations; ``shift``:
    how far the intercept moves before it learns, the change the other operations showed.
    """

    verdict: Verdict
    monitor: Monitor
    sigma: float = 0.0
    forget: float = 0.0
    held: Reading | None = None
    innovation: tuple[float, float] | None = None
    shift: float = 0.0

    @property
    def learns(self) -> bool:
        """Whether anything is learned from the reading."""
        return self.verdict != "quarantine"

    @property
    def changed(self) -> bool:
        """Whether the reading shows the process changed (note ``regime_change``)."""
        return self.verdict in ("change", "confirm")


def _low_side(
    monitor: Monitor,
    low: Expected,
    reading: Reading,
    variance: float,
    exponents: Mapping[str, float],
    exponent_sd: float,
) -> Watched | None:
    """A held reading the new one confirms, or a reading too good to be true; else None."""
    held = monitor.held
    if (
        held is not None
        and held.ln_y - low.mean >= -CONFIRMABLE
        and _consistent(held, reading, monitor.scale, exponents, exponent_sd)
    ):
        e = held.ln_y - low.mean
        forget = max(e * e - _variance(low, held.noise, variance), 0.0)
        counted = replace(monitor, held=None, changes=monitor.changes + 1)
        return Watched("confirm", counted, _sigma(low, reading, variance), forget, held)
    r_low = _sigma(low, reading, variance)
    under_half = reading.ln_y - low.mean < -(CONFIRMABLE + COVERAGE_FACTOR * low.sd)
    if r_low < -LOW_SIGMA or under_half:
        kept = replace(monitor, held=reading, quarantined=monitor.quarantined + 1)
        return Watched("quarantine", kept, r_low)
    return None


def _noise_learned(
    monitor: Monitor,
    high: Expected,
    reading: Reading,
    e: float,
    r_high: float,
    variance: float,
    common: bool,
) -> Monitor:
    """The noise scales learned from the innovation, by the share of it that is noise.

    A change counts as a reading at the alarm's edge (it cannot be told from noise by
    itself); a reading of a common change, or after the setpoint moved too far to tell the
    noise from the model, teaches nothing. ``e``: the innovation ``ln y`` less ``high``'s mean.
    """
    unit = high.noise**2 + reading.noise**2
    model2 = (high.sd if high.estimate_sd is None else high.estimate_sd) ** 2
    weight = variance * unit / (model2 + variance * unit)
    if high.shift**2 > unit or common:
        weight = 0.0  # the setpoint moved too far to tell the noise from the model; a change
    own = weight  # a drift in progress off a model's expectation: not noise to the alarm
    if high.noise == 0.0 and monitor.cusum + r_high - CUSUM_K > DRIFTING:
        own = 0.0
    e2 = min(e * e, CHANGE_SIGMA**2 * _variance(high, reading.noise, variance))
    excess = max(e2 - model2, 0.0) / unit
    test = 0.0
    if noise_watch.watched_monitor(monitor):  # against λ of the chain's evidence
        test = weight * noise_watch.llr(excess / max(monitor.chain_rate / monitor.chain_shape, 1.0))
    kept_shape, kept_rate = monitor.chain_kept(NOISE_KEEP**weight)
    return replace(
        monitor,
        shape=monitor.shape + 0.5 * own,
        rate=monitor.rate + 0.5 * own * excess,
        chain_shape=kept_shape + 0.5 * weight,
        chain_rate=kept_rate + 0.5 * weight * excess,
        noise_llr=test,
    )


def watch(
    monitor: Monitor,
    low: Expected,
    high: Expected | None,
    measurement: Measurement,
    point: Mapping[str, float],
    exponents: Mapping[str, float],
    exponent_sd: float,
    common: tuple[float, float] | None = None,
) -> Watched:
    """Classify a reading against what the strategy expects (module docstring).

    ``low`` and ``high``: the expectation each side is judged against (``high`` None: no
    change is looked for, and the noise scale does not learn). ``common``: the readings of
    this quantity in the part's operations moved up together (:mod:`supervisor.rcb.
    common_cause`), by ``(shift, variance)`` as the others show it: a reading judged on the
    high side is then a change that moves the intercept by ``shift`` and discounts
    ``variance``, and teaches the noise scale nothing. The monitor returned holds
    the quarantined reading (or has dropped it), the counts and the noise scale;
    :func:`learned` makes the reading the last one once it is learned from.
    """
    y, u = measurement.value, measurement.uncertainty
    if not (y > 0 and u > 0):  # nothing to judge in logs (a zero reading is the law's)
        return Watched("accept", replace(monitor, held=None))
    reading = _reading_of(measurement, point)
    variance = monitor.scale**2
    on_low = _low_side(monitor, low, reading, variance, exponents, exponent_sd)
    if on_low is not None:
        return on_low
    monitor = replace(monitor, held=None)
    if high is None:
        return Watched("accept", monitor)
    e = reading.ln_y - high.mean
    r_high = _sigma(high, reading, variance)
    monitor = _noise_learned(monitor, high, reading, e, r_high, variance, common is not None)
    spread2 = _variance(high, reading.noise, variance)
    innovation = (e, spread2)
    if common is not None or r_high > CHANGE_SIGMA:  # a change at once
        counted = replace(monitor, changes=monitor.changes + 1, cusum=0.0, drift_sum=0.0, drift_n=0)
        shift, forget = common or (0.0, max(e * e - spread2, 0.0))
        return Watched("change", counted, r_high, forget, None, innovation, shift)
    cusum = max(monitor.cusum + r_high - CUSUM_K, 0.0)
    if cusum == 0.0:
        reset = replace(monitor, cusum=0.0, drift_sum=0.0, drift_n=0)
        return Watched("accept", reset, innovation=innovation)
    drift_sum, drift_n = monitor.drift_sum + e, monitor.drift_n + 1
    if cusum > CUSUM_H:  # readings a little over, part after part: a change too
        shift = drift_sum / drift_n
        counted = replace(monitor, changes=monitor.changes + 1, cusum=0.0, drift_sum=0.0, drift_n=0)
        forget = max(shift * shift - spread2 / drift_n, 0.0)
        return Watched("change", counted, cusum, forget, innovation=innovation)
    drifting = replace(monitor, cusum=cusum, drift_sum=drift_sum, drift_n=drift_n)
    return Watched("accept", drifting, innovation=innovation)


def learned(
    monitor: Monitor, measurement: Measurement, point: Mapping[str, float], age: int | None
) -> Monitor:
    """The monitor once the reading is learned from: it is the chain's last reading."""
    if not (measurement.value > 0 and measurement.uncertainty > 0):
        return replace(monitor, last=None)
    return replace(monitor, last=_reading_of(measurement, point, age))


def _reading_of(
    measurement: Measurement, point: Mapping[str, float], age: int | None = None
) -> Reading:
    """A reading (``y > 0``, ``u > 0``) as the monitor keeps it."""
    y, u = measurement.value, measurement.uncertainty
    return Reading(math.log(y), (u / COVERAGE_FACTOR) / y, _logs(point), age)


def _logs(point: Mapping[str, float]) -> dict[str, float]:
    return {name: math.log(value) for name, value in point.items() if value > 0}


def _variance(expected: Expected, noise: float, scale2: float) -> float:
    """The variance of a reading's innovation: the expectation's, and the noise at ``ŝ²``."""
    return expected.sd**2 + scale2 * (expected.noise**2 + noise**2)


def _sigma(expected: Expected, reading: Reading, scale2: float) -> float:
    """``r``: the reading's distance from the expectation in σ of both."""
    return (reading.ln_y - expected.mean) / math.sqrt(_variance(expected, reading.noise, scale2))


def _difference(
    before: Reading, after: Reading, exponents: Mapping[str, float], exponent_sd: float
) -> tuple[float, float]:
    """``d`` of two readings and the variance a wrong exponent makes of the setpoint's change."""
    shift, misfit = setpoint_shift(before.ln_x, after.ln_x, exponents, exponent_sd)
    return after.ln_y - before.ln_y - shift, misfit


def _consistent(
    held: Reading, now: Reading, scale: float, exponents: Mapping[str, float], exponent_sd: float
) -> bool:
    """Whether ``now`` confirms ``held``: within :data:`CONFIRM_SIGMA` of their joint noise."""
    if set(held.ln_x) != set(now.ln_x):
        return False
    d, misfit = _difference(held, now, exponents, exponent_sd)
    joint = math.sqrt(scale**2 * (held.noise**2 + now.noise**2) + misfit)
    return abs(d) <= CONFIRM_SIGMA * joint


def chain(
    monitor: Monitor,
    point: Mapping[str, float],
    exponents: Mapping[str, float],
    exponent_sd: float,
    age: int | None = None,
    rise: tuple[float, float] | None = None,
) -> Expected | None:
    """The last reading learned from, moved to ``point`` with the model's exponents.

    Its spread is the last reading's noise (counted at the measured scale) and what an exponent
    wrong by its prior spread makes of the setpoint's change. ``rise``: the mean and variance
    of a worn edge's rise per part (:mod:`supervisor.rcb.wear`), added over the parts since
    the last reading of the same edge. None before the first reading, and for a new edge.
    """
    last = monitor.last
    now = _logs(point)
    if last is None or set(last.ln_x) != set(now):
        return None
    shift, misfit = setpoint_shift(last.ln_x, now, exponents, exponent_sd)
    mean = last.ln_y + shift
    if rise is not None and age is not None and last.age is not None:
        if age < last.age:  # a new edge: its level is not the worn one's
            return None
        steps = age - last.age
        mean += rise[0] * steps
        misfit += rise[1] * steps**2
    return Expected(mean, math.sqrt(misfit), last.noise, shift)
