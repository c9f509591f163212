r"""Borangiu et al.'s corrective actions WINC/WDEC/NINC/NDEC (IFAC 2007, §4, Table 1).

Each sample (one spindle revolution, §4 step 4) the working point ``(w, n)`` (feed rate,
spindle speed) is checked against the allowable domain, constraints (2)-(7), and every
violated class of Table 1 asks for a change:

======================  ==========================================  =========  =========
class                   violated constraint                         ``w``      ``n``
======================  ==========================================  =========  =========
R1 "max. chip load"     torque / deflection (2), (3), pitch feed    ``−Δw``    ``+Δn``
                        above its maximum (4 right)
R2 "max. power"         power (7) [and the cost curve (12)], feed   ``−Δw``    ``−Δn``
                        above its maximum (5 right)
R3 "unloaded"           pitch feed below its minimum (4 left)       ``+Δw``    ``−Δn``
R4 "speed"              spindle speed outside (6)                   ``w`` = ct ``∓Δn``
R5 "min. feed"          feed below its minimum (5 left)             ``+Δw``    ``n`` = ct
======================  ==========================================  =========  =========

``WINC``/``WDEC``/``NINC``/``NDEC`` are set (0 or 1) by the classes that ask for them, and

.. math:: w_{k+1} = \begin{cases} w_k + (\mathrm{WINC} - \mathrm{WDEC})\,\Delta w &
          \mathrm{WINC} \ne \mathrm{WDEC} \\ w_k + \Delta w & \mathrm{WINC} = \mathrm{WDEC}
          \end{cases}, \qquad n_{k+1} = n_k + (\mathrm{NINC} - \mathrm{NDEC})\,\Delta n

so inside the allowable area (no violation) the feed rises by ``Δw`` ("which optimizes the
throughput"), and the total change stays one increment when several classes are violated.
Table 1 and the formula disagree for R4 alone (``w`` = ct in the table, ``WINC = WDEC = 0``
gives ``+Δw`` in the formula): the table is followed, a violation that asks nothing of ``w``
holds it; ``+Δw`` for ``WINC = WDEC`` applies inside the area and when both are asked for.

Readings. The load constraints (2)-(3) are checked on the measured force against its
reference: ``F > F_ref`` is an R1 violation (the paper measures the bending torque ``M_d``,
a maximum per revolution, like Kim & Jeon's ``F_max``). The power is ``F·v/60000`` kW with
``v = π D n/1000``. The cost curve (12) needs Taylor tool-life constants the paper does not
give and is left out. Both commands are also clamped to their limits (the brief's contract
for every controller), so in the loop R5, R4 and the feed half of R2 only act if a limit is
met exactly; :func:`borangiu_violations` and :func:`borangiu_increments` keep the whole
table for direct use. The printed sample period ``16.(6)/n_k`` ms is read as one revolution,
``60/n`` s for ``n`` in rpm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from models import fields
from models.errors import InputError
from models.kinematics import cutting_power_kW
from supervisor.virtual.mill.controllers.base import ClampedFeed
from supervisor.virtual.mill.feed_limits import FeedLimits

#: Table 1: the sign of the change of ``w`` and of ``n`` each violated class asks for.
TABLE_1: dict[str, tuple[int, int]] = {
    "R1_max_chip_load": (-1, +1),
    "R2_max_power": (-1, -1),
    "R3_unloaded": (+1, -1),
    "R4_speed_above_max": (0, -1),
    "R4_speed_below_min": (0, +1),
    "R5_min_feed": (+1, 0),
}


@dataclass(frozen=True)
class CorrectiveConfig:
    """Increments and the limits of the allowable domain besides the feed limits.

    Parameters
    ----------
    feed_step_mm_min : float
        ``Δw`` [mm/min], ``> 0``. 2 mm/min per revolution (chosen: 50 mm/min per second at
        1500 rpm brings Case 1 from 60 to 190 mm/min in under 3 s, while the limit cycle
        about the reference stays within about ±3 % of 160 N at 3 mm depth).
    spindle_step_rpm : float
        ``Δn`` [rpm], ``>= 0`` (0: the spindle speed is held, as in Kim & Jeon's Case 1).
    min_spindle_rpm, max_spindle_rpm : float
        Constraint (6) [rpm].
    min_feed_per_rev_mm, max_feed_per_rev_mm : float
        Pitch feed ``w/n`` limits, constraint (4) [mm/rev].
    max_power_kW : float
        Constraint (7) [kW] (``math.inf``: none).
    tool_diameter_mm : float
        Tool diameter for the cutting speed of the power [mm].
    """

    feed_step_mm_min: float = 2.0
    spindle_step_rpm: float = 0.0
    min_spindle_rpm: float = 0.0
    max_spindle_rpm: float = math.inf
    min_feed_per_rev_mm: float = 0.0
    max_feed_per_rev_mm: float = math.inf
    max_power_kW: float = math.inf
    tool_diameter_mm: float = 10.0

    def __post_init__(self) -> None:
        fields.check_fields(
            self,
            positives=("feed_step_mm_min", "tool_diameter_mm"),
            non_negatives=("spindle_step_rpm", "min_spindle_rpm", "min_feed_per_rev_mm"),
        )
        for low, high in (
            ("min_spindle_rpm", "max_spindle_rpm"),
            ("min_feed_per_rev_mm", "max_feed_per_rev_mm"),
        ):
            value = getattr(self, high)
            if math.isnan(value) or value <= getattr(self, low):
                raise InputError(high, value, f"must be above {low} = {getattr(self, low):g}")
        if math.isnan(self.max_power_kW) or self.max_power_kW <= 0:
            raise InputError("max_power_kW", self.max_power_kW, "must be greater than 0")


def borangiu_violations(
    force_N: float,
    reference_force_N: float,
    feed_rate_mm_min: float,
    spindle_rpm: float,
    limits: FeedLimits,
    config: CorrectiveConfig,
) -> tuple[str, ...]:
    """Classes of Table 1 violated at a working point, in the order of :data:`TABLE_1`.

    Parameters
    ----------
    force_N : float
        Measured load (maximum force per revolution) [N].
    reference_force_N : float
        Its allowed maximum, the reference [N].
    feed_rate_mm_min : float
        Feed rate ``w`` [mm/min].
    spindle_rpm : float
        Spindle speed ``n`` [rpm], ``> 0``.
    limits : FeedLimits
        Constraint (5) [mm/min].
    config : CorrectiveConfig
        Constraints (4), (6), (7).

    Returns
    -------
    tuple of str
        Keys of :data:`TABLE_1`; empty inside the allowable area.
    """
    n = fields.positive(spindle_rpm, "spindle_rpm")
    pitch = feed_rate_mm_min / n
    speed_m_min = math.pi * config.tool_diameter_mm * n / 1000.0
    power = cutting_power_kW(max(force_N, 0.0), speed_m_min)
    violated = {
        "R1_max_chip_load": force_N > reference_force_N or pitch > config.max_feed_per_rev_mm,
        "R2_max_power": power > config.max_power_kW
        or feed_rate_mm_min > limits.upper_feed_rate_mm_min,
        "R3_unloaded": pitch < config.min_feed_per_rev_mm,
        "R4_speed_above_max": n > config.max_spindle_rpm,
        "R4_speed_below_min": n < config.min_spindle_rpm,
        "R5_min_feed": feed_rate_mm_min < limits.lower_feed_rate_mm_min,
    }
    return tuple(name for name in TABLE_1 if violated[name])


def borangiu_increments(violations: tuple[str, ...]) -> tuple[int, int]:
    """Multiples of ``(Δw, Δn)`` to apply for the violated classes (Borangiu et al. §4).

    Parameters
    ----------
    violations : tuple of str
        Keys of :data:`TABLE_1`.

    Returns
    -------
    tuple[int, int]
        ``(WINC − WDEC, NINC − NDEC)``; the feed change is ``+1`` when ``WINC = WDEC``
        inside the allowable area or with increase and decrease both asked for, and 0 when
        only R4 ("w = ct") is violated.
    """
    winc = wdec = ninc = ndec = 0
    for name in violations:
        if name not in TABLE_1:
            raise InputError("violations", name, f"not a class of Table 1: {', '.join(TABLE_1)}")
        dw, dn = TABLE_1[name]
        winc, wdec = max(winc, int(dw > 0)), max(wdec, int(dw < 0))
        ninc, ndec = max(ninc, int(dn > 0)), max(ndec, int(dn < 0))
    if winc != wdec:
        feed = winc - wdec
    else:
        feed = 1 if winc or not violations else 0  # R4 alone: "w = ct" (Table 1)
    return feed, ninc - ndec


class BorangiuCorrectiveController(ClampedFeed):
    """Borangiu et al.'s corrective feed (and speed) control on a force, clamped to limits.

    Parameters
    ----------
    limits : FeedLimits
        Feed-rate limits [mm/min].
    config : CorrectiveConfig
        Increments and the other limits.
    """

    def __init__(self, limits: FeedLimits, config: CorrectiveConfig | None = None) -> None:
        super().__init__(limits, limits.lower_feed_rate_mm_min)
        self.config = config or CorrectiveConfig()
        self.last_violations: tuple[str, ...] = ()

    def reset(self, feed_rate_mm_min: float, spindle_rpm: float) -> None:
        """Start from a feed command [mm/min] and spindle speed [rpm] (the program's F, S)."""
        self._start(feed_rate_mm_min, spindle_rpm)
        self._spindle_rpm = self._clamp_speed(self._spindle_rpm)
        self.last_violations = ()

    def _clamp_speed(self, spindle_rpm: float) -> float:
        c = self.config
        return min(max(spindle_rpm, c.min_spindle_rpm), c.max_spindle_rpm)

    def step(self, measured: float, reference: float, dt_s: float) -> float:
        """Next feed command [mm/min] from the measured and reference forces [N]."""
        violations = borangiu_violations(
            measured, reference, self._command, self._spindle_rpm, self._limits, self.config
        )
        dw, dn = borangiu_increments(violations)
        self.last_violations = violations
        self._command = self._limits.clamp(self._command + dw * self.config.feed_step_mm_min)
        speed = self._spindle_rpm + dn * self.config.spindle_step_rpm
        self._spindle_rpm = self._clamp_speed(max(speed, self.config.spindle_step_rpm))
        return self._command
