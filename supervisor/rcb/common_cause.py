r"""A change every operation of a part shows at once: one cause, found and learned in one report.

A harder batch of material or another insert supplier raises the force and the roughness of
every cut of the part together; each operation's own alarm (:mod:`supervisor.rcb.monitor`)
sees only its share. Under a measuring chain three times noisier than it claims, a +12 % step
is about 3σ in one reading: under the one-reading alarm (:data:`~supervisor.rcb.monitor.
CHANGE_SIGMA`), found by each operation's CUSUM two or three parts later, and every part in
between crosses its limit (all five faults, 40 scenarios: 160 such crossings, 112 of them at
the two parts after the step).

**Finding it.** The readings of one quantity in the ``m`` operations of a report are
independent given the process, each judged on the high side as ``r_i = e_i/√v_i`` (its
innovation ``e_i`` over the innovation's variance ``v_i``), so Stouffer's combination

.. math:: Z = \frac{1}{\sqrt{m}} \sum_{i=1}^{m} r_i

is standard normal when nothing changed and grows as ``√m`` times a shift the operations share
[1]_; an innovation under ``−2σ`` counts at ``−2σ`` (:data:`FLOOR_SIGMA`, a winsorised sum [3]_:
a reading at 30 % of the truth that escaped quarantine, ``r ≈ −20``, would hide the rise).
``Z >`` :data:`COMMON_SIGMA` is a change of that quantity in every operation: 3.5, under the
one-reading alarm's 4 (a false alarm in 4 300 reports per quantity instead of 31 600; a
false alarm costs one discounted part). Measured on ``benchmarks/closed_loop.py``, 1000
scenarios x 30 parts, 2026-11-28: at 4, one step went unseen at ``Z = 3.97`` under all five
faults (five crossings at the next part); at 3.5 ``learn``'s avoidable crossings under all
five fell from 18 to 13 and ``ivester``'s from 35 to 34, with ``learn``'s clean figures the
same (0.9806 / p5 0.9731 after 10 parts, 0.9926 after 30) and 0 avoidable under the step
alone.

**Learning it.** Each operation's shift is the common one plus its own: ``e_i = δ + η_i +
ε_i`` with ``η_i ~ N(0, τ²)``, a random-effects model whose ``τ²`` is DerSimonian and Laird's
moment estimate [2]_ (``w_i = 1/v_i``, ``Q = Σ w_i (e_i − ē)²``):

.. math:: τ^2 = \max\left(0, \frac{Q − (m − 1)}{Σ w_i − Σ w_i^2 / Σ w_i}\right), \qquad
   \hat δ = \frac{Σ w^*_i e_i}{Σ w^*_i}, \quad \operatorname{Var} \hat δ = \frac{1}{Σ w^*_i},
   \quad w^*_i = \frac{1}{v_i + τ^2}

An operation's intercept moves by the shift the *other* operations show (``δ̂`` without its own
reading, so that its reading is not counted twice) and its variance grows by that estimate's
variance and ``τ²``; then its own reading is learned as usual. An operation whose reading was
quarantined (a dropout at the step) moves by the whole ``δ̂``: its next setpoint is safe against
the change it could not measure.

References
----------
.. [1] Stouffer, Suchman, DeVinney, Star & Williams (1949), The American Soldier, Vol. 1;
   Whitlock (2005), "Combining probability from independent tests: the weighted Z-method is
   superior to Fisher's approach", J. Evol. Biol. 18(5), 1368-1373.
.. [2] DerSimonian & Laird (1986), "Meta-analysis in clinical trials", Controlled Clinical
   Trials 7(3), 177-188.
.. [3] Huber (1964), "Robust estimation of a location parameter", Ann. Math. Statist. 35(1),
   73-101 (a bounded influence of each observation).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

#: The pooled ``Z`` over which a quantity changed in every operation of the part [σ]
#: (the module docstring: under the one-reading alarm, monitor.CHANGE_SIGMA).
COMMON_SIGMA = 3.5
#: An innovation under ``−FLOOR_SIGMA`` σ counts at that edge (winsorised): a sensor that
#: failed at the part of the change (a reading at 30 % of the truth is ``r ≈ −20``) must not
#: hide the others' rise, nor pull their shift down.
FLOOR_SIGMA = 2.0


@dataclass(frozen=True)
class CommonShift:
    """A quantity's common change in one report (module docstring).

    ``z``: Stouffer's ``Z``; ``innovations``: ``(e_i, v_i)`` of its readings on the high side;
    ``tau2``: the between-operation variance of the shift.
    """

    z: float
    innovations: tuple[tuple[float, float], ...]
    tau2: float

    def _weights(self) -> list[float]:
        return [1.0 / (v + self.tau2) for _, v in self.innovations]

    def shift(self, without: int | None = None) -> tuple[float, float]:
        """``(δ̂, Var δ̂ + τ²)``: the intercept's move and its added variance [ln].

        ``without``: the index of the reading the shift is for (left out of the estimate).
        """
        pairs = [
            (w, e)
            for i, (w, (e, _)) in enumerate(zip(self._weights(), self.innovations, strict=True))
            if i != without
        ]
        total = sum(w for w, _ in pairs)
        return sum(w * e for w, e in pairs) / total, 1.0 / total + self.tau2


def pooled_sigma(innovations: Sequence[tuple[float, float]]) -> float:
    """Stouffer's ``Z`` of readings' innovations ``(e, v)`` (0 for none)."""
    if not innovations:
        return 0.0
    return sum(e / math.sqrt(v) for e, v in innovations) / math.sqrt(len(innovations))


def between_variance(innovations: Sequence[tuple[float, float]]) -> float:
    """DerSimonian and Laird's ``τ²`` of the innovations' means (module docstring)."""
    weights = [1.0 / v for _, v in innovations]
    total = sum(weights)
    mean = sum(w * e for w, (e, _) in zip(weights, innovations, strict=True)) / total
    q = sum(w * (e - mean) ** 2 for w, (e, _) in zip(weights, innovations, strict=True))
    scale = total - sum(w * w for w in weights) / total
    return max(0.0, (q - (len(innovations) - 1)) / scale) if scale > 0 else 0.0


def common_shifts(items: Iterable[tuple[str, tuple[float, float]]]) -> dict[str, CommonShift]:
    """The quantities whose readings moved up together, with their shift.

    ``items``: ``(quantity, (e, v))`` of every reading of the report judged on the high side,
    in the order the report is applied. A quantity read in fewer than two operations has no
    common cause to show beyond its own alarm.
    """
    by_quantity: dict[str, list[tuple[float, float]]] = {}
    for quantity, (e, v) in items:
        by_quantity.setdefault(quantity, []).append((max(e, -FLOOR_SIGMA * math.sqrt(v)), v))
    out = {}
    for quantity, innovations in by_quantity.items():
        z = pooled_sigma(innovations)
        if len(innovations) >= 2 and z > COMMON_SIGMA:
            out[quantity] = CommonShift(z, tuple(innovations), between_variance(innovations))
    return out
