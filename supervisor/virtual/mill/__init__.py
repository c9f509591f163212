"""The virtual mill: inner feed-control loops on a step-depth workpiece, and an edge's life.

Its force models (Kim & Jeon Eq. 1, or a power law) are pure physics, in
:mod:`models.milling_force`; the paper numbers of its cases are data, in ``models/data/``.

- :mod:`~supervisor.virtual.mill.feed_limits`: the feed-rate limits every controller clamps to.
- :mod:`~supervisor.virtual.mill.process`: the plant (force → spindle current with idle offset,
  slope and wear term), the current sensor (lag, noise), wear growth, the workpiece.
- :mod:`~supervisor.virtual.mill.controllers`: Tai et al.'s PI (Eq. 16), Kim & Jeon's fuzzy
  controller (Table 2), Borangiu et al.'s corrective actions (Table 1).
- :mod:`~supervisor.virtual.mill.run`: the time-stepping loop and its frozen results.
- :mod:`~supervisor.virtual.mill.case1`: Kim & Jeon's Case 1 (depth 1.5 → 3.0 → 1.5 mm), its
  numbers read from ``models/data/kim_jeon_case1.toml``.
- :mod:`~supervisor.virtual.mill.tai_end_milling`: Tai et al.'s end milling (current plane, feed
  limits, cut), read from ``models/data/tai_end_milling.toml``.
- :mod:`~supervisor.virtual.mill.edge_life`: constant-load milling to the tool change (Tai et al.).

Everything is deterministic given the ``numpy.random.Generator`` passed in.
"""

from supervisor.virtual.mill.case1 import (
    CONTROLLERS,
    KIM_JEON_FEED_LIMITS,
    KIM_JEON_REFERENCE_FORCE_N,
    case1_controller,
    case1_setup,
    kim_jeon_case1_workpiece,
    run_case1,
)
from supervisor.virtual.mill.edge_life import (
    EdgeLifeConfig,
    EdgeLifeResult,
    PassSummary,
    simulate_edge_life,
    tai_wear_at_feed_mm,
)
from supervisor.virtual.mill.feed_limits import FeedLimits
from supervisor.virtual.mill.process import (
    CurrentSensor,
    ForceCurrentMill,
    StepWorkpiece,
    TaiMill,
    WearLaw,
)
from supervisor.virtual.mill.run import MillRun, MillSetup, SegmentMetrics, simulate

__all__ = [
    "CONTROLLERS",
    "KIM_JEON_FEED_LIMITS",
    "KIM_JEON_REFERENCE_FORCE_N",
    "CurrentSensor",
    "EdgeLifeConfig",
    "EdgeLifeResult",
    "FeedLimits",
    "ForceCurrentMill",
    "MillRun",
    "MillSetup",
    "PassSummary",
    "SegmentMetrics",
    "StepWorkpiece",
    "TaiMill",
    "WearLaw",
    "case1_controller",
    "case1_setup",
    "kim_jeon_case1_workpiece",
    "run_case1",
    "simulate",
    "simulate_edge_life",
    "tai_wear_at_feed_mm",
]
