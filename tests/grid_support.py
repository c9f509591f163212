"""Helpers of the setpoint grid tests (tests/supervisor/test_setpoint_resolution.py,
test_setpoint_grid_rule.py): whether a value is on a step's grid, and random resolutions."""

from __future__ import annotations

from decimal import Decimal

from hypothesis import strategies as st


def on_grid(value: float, step: float) -> bool:
    """``value`` is a whole number of ``step`` as written (decimal arithmetic)."""
    return Decimal(repr(value)) % Decimal(repr(step)) == 0


#: Resolutions (steps) of depth, feed and speed, a few orders of magnitude each.
steps = st.fixed_dictionaries(
    {
        "depth_mm": st.sampled_from([0.1, 0.01, 0.001]),
        "feed_mm_rev": st.sampled_from([0.01, 0.001, 0.0001]),
        "speed_m_min": st.sampled_from([5.0, 1.0, 0.5, 0.1]),
    }
)
