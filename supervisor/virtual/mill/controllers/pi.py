r"""Tai et al.'s PI feed control on the spindle current (Eq. 16), clamped to the feed limits.

Eq. 16 reads ``U = U_0 + K_p e(t) + K_i ∫_0^t e dt`` with "``U_0`` the last control signal"
and ``e`` the set value minus the measured value. Taken literally, in samples ``k``:

.. math:: U_k = U_{k-1} + K_p e_k + K_i \sum_{j \le k} e_j \Delta t,
          \qquad e_k = I_\text{ref} - I_k

with ``U`` the feed-rate command [mm/min], ``e`` in A and the override updated at 50 Hz
(§II.D). This reading is the one the paper's own numbers support: with the current's
sensitivity ``B = 1.2416e-4 A/(mm/min)`` of its end milling (see
:mod:`supervisor.virtual.mill.tai_end_milling`) the loop gain per sample is
``K_p B = 160 × 1.2416e-4 = 0.0199``; the error then decays by that fraction per sample, a
10-90 % rise in ``ln 9 / 0.0201 = 110`` samples (2.19 s) and a 2 % settling in
``ln 50 / 0.0201 = 195`` samples (3.9 s): the paper's design targets "rising time 2 s,
settling time 4 s" (§III.B). A positional reading with a fixed ``U_0`` would move the feed
by 1.6 mm/min for a 0.01 A error and, with ``K_i = 0.006``, could not hold the current.
The ``K_i`` term, a second integral in this reading, is four orders of magnitude weaker and
is kept as printed. It is frozen while the command sits on a limit and the error pushes it
further out (conditional integration against wind-up; the paper says nothing on this).

For another plant, :func:`tai_pi_gains_for` scales both gains so that the loop keeps the
paper's gain per second (and so its 2 s rise) at that plant's current-per-feed sensitivity.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from models import fields
from supervisor.virtual.mill.controllers.base import ClampedFeed
from supervisor.virtual.mill.feed_limits import FeedLimits
from supervisor.virtual.mill.tai_end_milling import TAI_END_MILLING, TAI_SAMPLE_PERIOD_S


@dataclass(frozen=True)
class TaiPIGains:
    """Gains of Eq. 16 in the incremental reading (see the module).

    Parameters
    ----------
    kp_mm_min_per_A : float
        ``K_p``, feed change per sample per ampere of error [(mm/min)/A], ``>= 0``.
    ki_mm_min_per_A_s : float
        ``K_i``, feed change per sample per ampere-second of accumulated error
        [(mm/min)/(A·s)], ``>= 0``.
    """

    kp_mm_min_per_A: float = 160.0
    ki_mm_min_per_A_s: float = 0.006

    def __post_init__(self) -> None:
        fields.check_fields(self, non_negatives=("kp_mm_min_per_A", "ki_mm_min_per_A_s"))


#: Tai et al. §III.B: ``K_p = 160``, ``K_i = 0.006`` (end and slot milling).
TAI_PI_GAINS = TaiPIGains()


def tai_pi_gains_for(
    current_per_feed_A_per_mm_min: float,
    sample_period_s: float,
    gains: TaiPIGains = TAI_PI_GAINS,
) -> TaiPIGains:
    r"""Gains that give another plant the loop speed of Tai et al.'s design.

    .. math:: K' = K \, \frac{B_\text{Tai}}{G} \, \frac{\Delta t'}{\Delta t_\text{Tai}}

    keeps the loop gain per second ``K_p G / Δt`` of the paper's end milling
    (``B_Tai = 1.2416e-4 A/(mm/min)``, ``Δt = 0.02 s``).

    Parameters
    ----------
    current_per_feed_A_per_mm_min : float
        ``G = ∂I/∂f`` of the plant at its operating point [A/(mm/min)], ``> 0``.
    sample_period_s : float
        The plant's sample period [s], ``> 0``.
    gains : TaiPIGains
        Gains to scale (default the paper's).

    Returns
    -------
    TaiPIGains
        Scaled gains.
    """
    g = fields.positive(current_per_feed_A_per_mm_min, "current_per_feed_A_per_mm_min")
    dt = fields.positive(sample_period_s, "sample_period_s")
    factor = TAI_END_MILLING.slope_A_per_mm_min / g * dt / TAI_SAMPLE_PERIOD_S
    return replace(
        gains,
        kp_mm_min_per_A=gains.kp_mm_min_per_A * factor,
        ki_mm_min_per_A_s=gains.ki_mm_min_per_A_s * factor,
    )


class TaiPIController(ClampedFeed):
    """Tai et al. Eq. 16 on the spindle current, clamped to the feed limits.

    Parameters
    ----------
    limits : FeedLimits
        Feed-rate limits [mm/min].
    gains : TaiPIGains
        ``K_p`` and ``K_i`` (default the paper's).
    """

    def __init__(self, limits: FeedLimits, gains: TaiPIGains = TAI_PI_GAINS) -> None:
        super().__init__(limits, limits.upper_feed_rate_mm_min)
        self.gains = gains
        self._integral_A_s = 0.0

    def reset(self, feed_rate_mm_min: float, spindle_rpm: float) -> None:
        """Start from a feed command [mm/min] (clamped) with no accumulated error."""
        self._start(feed_rate_mm_min, spindle_rpm)
        self._integral_A_s = 0.0

    def step(self, measured: float, reference: float, dt_s: float) -> float:
        """Next feed command [mm/min] from the measured and reference currents [A]."""
        error = reference - measured
        integral = self._integral_A_s + error * dt_s
        raw = (
            self._command
            + self.gains.kp_mm_min_per_A * error
            + self.gains.ki_mm_min_per_A_s * integral
        )
        command = self._limits.clamp(raw)
        if command == raw or (raw > command) != (error > 0):
            self._integral_A_s = integral
        self._command = command
        return command
