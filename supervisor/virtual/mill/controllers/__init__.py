"""Feed controllers of the virtual mill: Tai's PI, Kim & Jeon's fuzzy, Borangiu's corrective."""

from supervisor.virtual.mill.controllers.base import FeedController
from supervisor.virtual.mill.controllers.corrective import (
    TABLE_1,
    BorangiuCorrectiveController,
    CorrectiveConfig,
    borangiu_increments,
    borangiu_violations,
)
from supervisor.virtual.mill.controllers.fuzzy import (
    FuzzyScaling,
    KimJeonFuzzyController,
    fuzzy_output,
    memberships,
)
from supervisor.virtual.mill.controllers.fuzzy_rules import LEVELS, RULES, rule
from supervisor.virtual.mill.controllers.pi import (
    TAI_PI_GAINS,
    TaiPIController,
    TaiPIGains,
    tai_pi_gains_for,
)

__all__ = [
    "LEVELS",
    "RULES",
    "TABLE_1",
    "TAI_PI_GAINS",
    "BorangiuCorrectiveController",
    "CorrectiveConfig",
    "FeedController",
    "FuzzyScaling",
    "KimJeonFuzzyController",
    "TaiPIController",
    "TaiPIGains",
    "borangiu_increments",
    "borangiu_violations",
    "fuzzy_output",
    "memberships",
    "rule",
    "tai_pi_gains_for",
]
