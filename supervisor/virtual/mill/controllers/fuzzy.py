r"""Kim & Jeon's fuzzy-logic feed controller (Precision Engineering 2011, §4.3, Table 2).

Each sample (one spindle revolution, §4.1):

.. math:: E = F_d - F_\max, \quad \bar E = \frac{E}{F_d}, \quad
          \overline{CE} = \frac{E_k - E_{k-1}}{F_d} \quad \text{(Eq. 5)}, \qquad
          f_d(k) = f_d(k-1) + K_v\,\overline{CO}(k) \quad \text{(Eq. 6)}

``Ē`` and ``CĒ`` are fuzzified over the 11 levels NVB … PVB, each pair of levels fires its
Table 2 rule (:mod:`~supervisor.virtual.mill.controllers.fuzzy_rules`), and the output is
defuzzified into ``CŌ`` in ``[−1, 1]``.

Membership functions. Fig. 4 of the paper is not given in numbers ("obtained by trial and
error"), so they are chosen here, in the shapes the figure describes: triangles evenly
spaced on each normalised universe, shoulders (membership 1 beyond the centre) for NVB and
PVB, and for ``Ē`` a deadband: ZO is 1 on ``|Ē| ≤ deadband`` and the other sets start
beyond it. Adjacent sets cross at 0.5, so the memberships of each input sum to 1.

Inference and defuzzification. Product inference (a rule fires with ``μ_E·μ_CE``), output
sets congruent triangles centred at ``rank·output_step``, sum aggregation and the centroid,
which for congruent triangles scaled by their firing strengths is the firing-weighted mean
of the centres:

.. math:: \overline{CO} = \sum_{i,j} \mu_{E,i}\,\mu_{CE,j}\; c\big(R_{ij}\big)

Scaling (chosen, with the reasons in :class:`FuzzyScaling`): deadband ±2 % of ``F_d``, error
sets every 5 % beyond it (PVB from 27 %), change sets every 2 % per sample, output
``K_v = 4 mm/min`` per unit ``CŌ``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from models import fields
from supervisor.virtual.mill.controllers.base import ClampedFeed
from supervisor.virtual.mill.controllers.fuzzy_rules import RULES, rank
from supervisor.virtual.mill.feed_limits import FeedLimits


@dataclass(frozen=True)
class FuzzyScaling:
    """Universes of the normalised inputs and output, and the output gain.

    Parameters
    ----------
    deadband : float
        Half-width of the ZO plateau of ``Ē`` [-] (Kim & Jeon Fig. 4a). 0.02: a steady force
        stays within ±2 % of ``F_d``, well inside a ±5 % tolerance, and twice the 1 % noise
        of a spindle-current force estimate does not drive the feed (§5.2: "the deadband
        prevented unacceptable vibration in the feed command").
    error_step : float
        Spacing of the ``Ē`` sets beyond the deadband [-]; 0.05 puts PVB at 27 %.
    change_step : float
        Spacing of the ``CĒ`` sets [-]; 0.02 per sample (a 2 % jump per revolution is NVS or
        PVS, a depth step doubling the force is NVB).
    output_step : float
        Spacing of the ``CŌ`` set centres [-]; 0.2 makes PVB = 1.
    kv_mm_min : float
        ``K_v`` of Eq. 6 [mm/min]; 4 mm/min (chosen in simulation: on Case 1 the loop gain is
        then about 0.06 per sample at 1.5 mm and 0.15 at 3.0 mm, well damped at both, and the
        largest change 100 mm/min per second at 1500 rpm).
    """

    deadband: float = 0.02
    error_step: float = 0.05
    change_step: float = 0.02
    output_step: float = 0.2
    kv_mm_min: float = 4.0

    def __post_init__(self) -> None:
        fields.check_fields(
            self,
            positives=("error_step", "change_step", "output_step", "kv_mm_min"),
            non_negatives=("deadband",),
        )


def memberships(value: float, step: float, deadband: float = 0.0) -> tuple[float, ...]:
    """Degrees of membership of ``value`` in the 11 levels NVB … PVB.

    Parameters
    ----------
    value : float
        Normalised input [-].
    step : float
        Distance between the centres of adjacent sets [-], ``> 0``.
    deadband : float
        Half-width of the ZO plateau [-], ``>= 0``; the centre of level ``r ≠ 0`` is at
        ``sign(r)·(deadband + |r|·step)``.

    Returns
    -------
    tuple of 11 float
        Degrees in [0, 1], summing to 1; at most two are non-zero.
    """
    if math.isnan(value):
        raise ValueError("value = nan: a membership needs a number")
    magnitude = min(max(abs(value) - deadband, 0.0) / step, 5.0)
    u = magnitude if value >= 0 else -magnitude
    lower = math.floor(u)
    frac = u - lower
    degrees = [0.0] * 11
    degrees[lower + 5] = 1.0 - frac
    if frac > 0.0:
        degrees[lower + 6] = frac
    return tuple(degrees)


def fuzzy_output(error_norm: float, change_norm: float, scaling: FuzzyScaling) -> float:
    """Defuzzified ``CŌ`` in [−1, 1] for normalised error and change (Table 2).

    Parameters
    ----------
    error_norm : float
        ``Ē = (F_d − F_max)/F_d`` [-].
    change_norm : float
        ``CĒ = (E_k − E_{k−1})/F_d`` [-].
    scaling : FuzzyScaling
        Universes and deadband.

    Returns
    -------
    float
        ``CŌ`` [-], positive for a feed increase.
    """
    mu_e = memberships(error_norm, scaling.error_step, scaling.deadband)
    mu_ce = memberships(change_norm, scaling.change_step)
    out = 0.0
    for i, a in enumerate(mu_e):
        if a == 0.0:
            continue
        for j, b in enumerate(mu_ce):
            if b != 0.0:
                out += a * b * rank(RULES[i][j]) * scaling.output_step
    # the weights sum to 1 (the memberships are partitions of unity), so ``out`` is in the
    # output universe [-1, 1]; the clamp takes off what rounding adds (-1.0000000000000002)
    return min(1.0, max(-1.0, out))


class KimJeonFuzzyController(ClampedFeed):
    """Kim & Jeon's fuzzy feed controller on a force, clamped to the feed limits.

    Parameters
    ----------
    limits : FeedLimits
        Feed-rate limits [mm/min].
    scaling : FuzzyScaling
        Memberships, deadband and ``K_v``.
    """

    def __init__(self, limits: FeedLimits, scaling: FuzzyScaling | None = None) -> None:
        super().__init__(limits, limits.lower_feed_rate_mm_min)
        self.scaling = scaling or FuzzyScaling()
        self._previous_error: float | None = None

    def reset(self, feed_rate_mm_min: float, spindle_rpm: float) -> None:
        """Start from a feed command [mm/min]; the first change of error is taken as 0."""
        self._start(feed_rate_mm_min, spindle_rpm)
        self._previous_error = None

    def step(self, measured: float, reference: float, dt_s: float) -> float:
        """Next feed command [mm/min] from the measured and reference forces [N]."""
        ref = fields.positive(reference, "reference")
        error = ref - measured
        previous = error if self._previous_error is None else self._previous_error
        self._previous_error = error
        out = fuzzy_output(error / ref, (error - previous) / ref, self.scaling)
        self._command = self._limits.clamp(self._command + self.scaling.kv_mm_min * out)
        return self._command
