"""The new F and S numbers: precision, rounding down, and the style of the original word."""

from __future__ import annotations

from decimal import ROUND_FLOOR, Decimal
from typing import Literal

#: Decimal places written for a feed per revolution [mm/rev].
FEED_MM_REV_PLACES = 4
#: Decimal places written for a feed per minute [mm/min].
FEED_MM_MIN_PLACES = 1
#: Decimal places written for a spindle speed (m/min under G96, rpm under G97).
SPEED_PLACES = 0

Quantity = Literal["feed_mm_rev", "feed_rate_mm_min", "speed_m_min", "spindle_rpm"]


def _floor(value: float, places: int) -> Decimal:
    """``value`` rounded down to ``places`` decimals, after float noise is removed.

    ``199.99999999999991`` (an optimum on a bound) is 200, not 199: the value is first
    rounded to 12 significant digits.
    """
    exact = Decimal(f"{value:.12g}")  # finite: OperationSetpoint checks it
    return exact.quantize(Decimal(1).scaleb(-places), rounding=ROUND_FLOOR)


def _styled(value: Decimal, original: str, places: int, *, point: bool) -> str:
    """``value`` written in the style of the number ``original`` (package docstring)."""
    sign = "+" if original.startswith("+") else ""
    body = original.lstrip("+-")
    integer, had_point, decimals = body.partition(".")
    whole, _, fraction = f"{value:.{places}f}".partition(".")
    fraction = fraction.rstrip("0").ljust(len(decimals), "0")
    if fraction:
        text = f"{whole}.{fraction}"
    elif had_point or point:
        text = f"{whole}."
    else:
        text = whole
    if not integer and whole == "0" and "." in text:
        text = text[1:]  # the original had no leading zero: ".25" → ".325"
    return sign + text
