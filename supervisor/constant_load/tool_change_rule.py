r"""The tool-change rule: change the tool when the commanded feed reaches the lower limit.

Tai et al. §III.C: "When the feedrate command touched the lower limit, it is indicated that the
tool wear reaches its limit and it needs to be replaced."
"""

from __future__ import annotations

from dataclasses import dataclass

from models.errors import InputError
from models.fields import number
from supervisor.constant_load.limits import ConstantLoadSetup

#: Relative tolerance of "reaches the lower limit" for rounding of the reported feed.
_REACHED_REL = 1e-9


@dataclass(frozen=True)
class ToolChangeDecision:
    """Whether the tool is due for a change, from the commanded feed (Tai et al. §III.C).

    Parameters
    ----------
    due : bool
        The commanded feed has reached the lower limit.
    feed_rate_mm_min : float
        Commanded feed rate [mm/min].
    lower_limit_mm_min : float
        The lower feed limit [mm/min].
    margin_mm_min : float
        ``feed − lower limit`` [mm/min]; ``<= 0`` (within tolerance) when due.
    flank_wear_mm : float
        Flank wear that Eq. 15 assigns to this feed at the reference current [mm] (0 above the
        upper limit); valid while the controller holds the reference current.
    reason : str
        One sentence for the operator and the log.
    """

    due: bool
    feed_rate_mm_min: float
    lower_limit_mm_min: float
    margin_mm_min: float
    flank_wear_mm: float
    reason: str


def tool_change_due(
    setup: ConstantLoadSetup,
    *,
    feed_rate_mm_min: float | None = None,
    feed_override_percent: float | None = None,
    programmed_feed_rate_mm_min: float | None = None,
    tolerance_mm_min: float = 0.0,
) -> ToolChangeDecision:
    r"""Flag a tool change when the commanded feed reaches the lower limit (Tai et al. §III.C).

    "When the feedrate command touched the lower limit, it is indicated that the tool wear
    reaches its limit and it needs to be replaced." Give the commanded feed rate, or the feed
    override the controller sends (Tai et al. §II.A: "constant load control was applied by
    real-time feedrate override"), a percentage of the programmed feed:

    .. math:: f = f_\text{programmed} \cdot \frac{\text{override}}{100}

    The programmed feed defaults to the upper feed limit (the part program runs at it and the
    controller only overrides down).

    Parameters
    ----------
    setup : ConstantLoadSetup
        Reference current and limits.
    feed_rate_mm_min : float, optional
        Commanded feed rate [mm/min], ``> 0``.
    feed_override_percent : float, optional
        Feed override [%], ``> 0`` (exactly one of the two).
    programmed_feed_rate_mm_min : float, optional
        Feed rate of the part program [mm/min] (with ``feed_override_percent`` only).
    tolerance_mm_min : float
        Resolution of the reported feed [mm/min]: due within this of the limit.

    Returns
    -------
    ToolChangeDecision
        Due or not, and why.
    """
    if (feed_rate_mm_min is None) == (feed_override_percent is None):
        raise InputError(
            "feed_rate_mm_min",
            feed_rate_mm_min,
            "give exactly one of feed_rate_mm_min and feed_override_percent",
        )
    tolerance = number(tolerance_mm_min, "tolerance_mm_min", minimum=0.0)
    feed = _commanded_feed_mm_min(
        setup, feed_rate_mm_min, feed_override_percent, programmed_feed_rate_mm_min
    )
    cal, lower = setup.calibration, setup.lower.feed_rate_mm_min
    margin = feed - lower
    due = margin <= tolerance + _REACHED_REL * lower
    wear = (
        setup.reference_current_A - cal.idle_current_A - cal.slope_A_per_mm_min * feed
    ) / cal.wear_coefficient_A_per_mm
    wear = max(wear, 0.0)
    reason = _reason(setup, due, feed, margin, wear)
    return ToolChangeDecision(due, feed, lower, margin, wear, reason)


def _commanded_feed_mm_min(
    setup: ConstantLoadSetup,
    feed_rate_mm_min: float | None,
    feed_override_percent: float | None,
    programmed_feed_rate_mm_min: float | None,
) -> float:
    """The commanded feed: given, or the override's percentage of the programmed feed.

    The programmed feed defaults to the upper limit (the part program runs at it and the
    controller only overrides down); it means nothing beside a commanded feed, so is refused.
    """
    if feed_override_percent is not None:
        override = number(feed_override_percent, "feed_override_percent", positive=True)
        programmed = setup.upper.feed_rate_mm_min
        if programmed_feed_rate_mm_min is not None:
            programmed = number(
                programmed_feed_rate_mm_min, "programmed_feed_rate_mm_min", positive=True
            )
        return programmed * override / 100.0
    if programmed_feed_rate_mm_min is not None:
        raise InputError(
            "programmed_feed_rate_mm_min",
            programmed_feed_rate_mm_min,
            "applies to feed_override_percent only",
        )
    return number(feed_rate_mm_min, "feed_rate_mm_min", positive=True)


def _reason(setup: ConstantLoadSetup, due: bool, feed: float, margin: float, wear: float) -> str:
    """One sentence for the operator and the log: change the tool, or keep cutting."""
    lower = setup.lower.feed_rate_mm_min
    lo, hi = (1000 * w for w in setup.wear_interval_mm)
    if due:
        return (
            f"change the tool: the commanded feed {feed:.1f} mm/min has reached the lower limit "
            f"{lower:.1f} mm/min (flank wear about {wear * 1000:.0f} µm, tool-change interval "
            f"{lo:g}-{hi:g} µm)"
        )
    return (
        f"keep cutting: the commanded feed {feed:.1f} mm/min is {margin:.1f} mm/min above "
        f"the lower limit {lower:.1f} mm/min (flank wear about {wear * 1000:.0f} µm)"
    )
