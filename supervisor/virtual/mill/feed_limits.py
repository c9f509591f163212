"""The feed-rate limits every controller of the virtual mill clamps its command to."""

from __future__ import annotations

import math
from dataclasses import dataclass

from models import fields
from models.errors import InputError


@dataclass(frozen=True)
class FeedLimits:
    """Lower and upper feed-rate limits every controller clamps its command to.

    Parameters
    ----------
    lower_feed_rate_mm_min : float
        Lower limit [mm/min], ``> 0``. Tai et al. (§II.A, Eq. 15): the feed rate at which the
        reference current is reached with the largest allowed flank wear.
    upper_feed_rate_mm_min : float
        Upper limit [mm/min], ``> lower``. Tai et al.: the feed rate at which a sharp tool
        draws the reference current; Kim & Jeon §5.2: a machine-protection limit (240 mpm).
    """

    lower_feed_rate_mm_min: float
    upper_feed_rate_mm_min: float

    def __post_init__(self) -> None:
        fields.check_fields(self, positives=("lower_feed_rate_mm_min", "upper_feed_rate_mm_min"))
        if self.upper_feed_rate_mm_min <= self.lower_feed_rate_mm_min:
            raise InputError(
                "upper_feed_rate_mm_min",
                self.upper_feed_rate_mm_min,
                f"must be above lower_feed_rate_mm_min = {self.lower_feed_rate_mm_min:g}",
            )

    def clamp(self, feed_rate_mm_min: float) -> float:
        """``feed_rate_mm_min`` limited to ``[lower, upper]`` [mm/min]; NaN is refused."""
        if math.isnan(feed_rate_mm_min):
            raise InputError("feed_rate_mm_min", feed_rate_mm_min, "must be a number")
        return min(max(feed_rate_mm_min, self.lower_feed_rate_mm_min), self.upper_feed_rate_mm_min)

    def at_lower(self, feed_rate_mm_min: float) -> bool:
        """Whether ``feed_rate_mm_min`` sits on the lower limit (to rounding) [mm/min]."""
        return feed_rate_mm_min <= self.lower_feed_rate_mm_min * (1.0 + 1e-12)
