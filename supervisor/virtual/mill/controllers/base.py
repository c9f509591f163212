"""What the time-stepping loop asks of a feed controller."""

from __future__ import annotations

from typing import Protocol

from models import fields
from supervisor.virtual.mill.feed_limits import FeedLimits


class FeedController(Protocol):
    """A feed-rate controller: one measurement in, one feed command out, per sample.

    Controllers keep their state (the last command, integrals, previous errors) between
    calls; :meth:`reset` starts them afresh. Every command is clamped to :attr:`limits`.
    """

    @property
    def limits(self) -> FeedLimits:
        """The feed-rate limits the command is clamped to."""
        ...

    @property
    def spindle_rpm(self) -> float:
        """The spindle-speed command [rpm] (constant unless the controller changes it)."""
        ...

    def reset(self, feed_rate_mm_min: float, spindle_rpm: float) -> None:
        """Start from a feed command [mm/min] and spindle speed [rpm]."""
        ...

    def step(self, measured: float, reference: float, dt_s: float) -> float:
        """The next feed command [mm/min] from a measurement and its reference.

        Parameters
        ----------
        measured : float
            The controlled signal as sampled (force [N] or spindle current [A]).
        reference : float
            Its reference, in the same unit.
        dt_s : float
            Time since the previous sample [s].
        """
        ...


class ClampedFeed:
    """What the controllers here share: the feed limits, the last command and the spindle speed.

    A controller adds its own state and ``step``; its ``reset`` starts with :meth:`_start`.
    """

    def __init__(self, limits: FeedLimits, command_mm_min: float) -> None:
        self._limits = limits
        self._command = command_mm_min
        self._spindle_rpm = 0.0

    @property
    def limits(self) -> FeedLimits:
        """Feed-rate limits [mm/min]."""
        return self._limits

    @property
    def spindle_rpm(self) -> float:
        """Spindle-speed command [rpm]: as set by ``reset``, unless the controller changes it."""
        return self._spindle_rpm

    def _start(self, feed_rate_mm_min: float, spindle_rpm: float) -> None:
        """Start from a feed command [mm/min] (clamped) and a spindle speed [rpm] (> 0)."""
        self._command = self._limits.clamp(feed_rate_mm_min)
        self._spindle_rpm = fields.positive(spindle_rpm, "spindle_rpm")
