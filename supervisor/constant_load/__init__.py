r"""Constant-load milling: reference current, feed-rate limits and the tool-change rule.

Modules: :mod:`~supervisor.constant_load.limits` (reference current and feed limits from a
fitted current plane), :mod:`~supervisor.constant_load.strength` (the reference current from a
tool's force limit), :mod:`~supervisor.constant_load.tool_change_rule` (change the tool when the
commanded feed reaches the lower limit), :mod:`~supervisor.constant_load.setpoint` (the
constant-load part of a milling setpoint, from ``[operations.constant_load]``) and
:mod:`~supervisor.constant_load.reported_tool_changes` (the tool changes a part report's feed
overrides call for).

Tai, Tsai & Li (IEEE Access 2023) hold the spindle current at a reference current by a feed
override (§II.A, Eq. 16) and set three numbers from constant-feed tests (§II.F, §III.A):

1. the reference current, a safety factor (0.85) times the largest current the tool withstood;
2. the upper feed limit, where the sharp-tool line (Eq. 13, Eq. 14 at ``VB = 0``) reaches it;
3. the lower feed limit, where the worn tool reaches it (Eq. 15) at the largest flank wear
   allowed; when the commanded feed falls to it the tool is changed (§III.C, Tables 1-2).

All three come from the plane ``I = A + B·f + k1·VB`` fitted to the tests
(:func:`models.sensors.fit_tai_calibration`). Bands are expanded, ``k·u`` with ``k = 2`` by
default, and are those of a *single cut*: first order (GUM Eq. 13) from the fit's covariance of
``(A, B, k1)``, ``s²(XᵀX)⁻¹``, plus the residual scatter ``s`` of the tests about the plane, so
they cover the tool-to-tool scatter the tests show (the paper's Table 1: 175-214 µm at change).

Which end of the wear interval
------------------------------
The paper sets the lower limit "when V_B reaches the maximum" (after Eq. 15; §II.C: "the end of
tool flank wear interval"), with the maximum wear an interval, 180-220 µm (§II.G: unstable wear
from 220-230 µm). Under constant load the feed follows Eq. 15 as the tool wears, so the wear at
the moment the feed reaches the lower limit is the wear Eq. 15 assigns to that feed. Here the
lower limit is Eq. 15 at the *worn* end (220 µm) raised by its band: a tool at the upper edge of
the band reaches 220 µm just at the limit, so the nominal wear at change lies inside the
interval, below its worn end by the band (about 210 µm on data like the paper's, which chose a
limit at 205 µm, "in the middle of the wear range"). Setting the limit at the sharp end (180 µm)
would throw away the rest of the interval; the paper calls its 180-190 µm slot-milling choice
"slightly conservative". A band wider than the interval is refused.

References
----------
.. [1] Tai, Tsai & Li, Establishment of Real-Time Adaptive Control Strategy for Milling
   Parameters, IEEE Access (2023): Eqs. 13-15, §II.F-G, §III.A, §III.C, Tables 1-2.
.. [2] Kim & Jeon, Precision Engineering (2011), §6.2.3: spindle current → force.
.. [3] JCGM 100:2008 (GUM), Eq. 13 and §6.2 (expanded uncertainty ``U = k·u``).
"""

from __future__ import annotations

from supervisor.constant_load.limits import (
    PAPER_SAFETY_FACTOR,
    PAPER_WEAR_INTERVAL_MM,
    ConstantLoadSetup,
    FeedLimit,
    Governor,
    constant_load_setup,
    limits_from_calibration,
)
from supervisor.constant_load.strength import COVERAGE_K, ForceLimit, strength_current_A
from supervisor.constant_load.tool_change_rule import ToolChangeDecision, tool_change_due

__all__ = [
    "COVERAGE_K",
    "PAPER_SAFETY_FACTOR",
    "PAPER_WEAR_INTERVAL_MM",
    "ConstantLoadSetup",
    "FeedLimit",
    "ForceLimit",
    "Governor",
    "ToolChangeDecision",
    "constant_load_setup",
    "limits_from_calibration",
    "strength_current_A",
    "tool_change_due",
]
