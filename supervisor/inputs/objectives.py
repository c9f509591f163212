"""What an operation's optimum is for: a plan's ``objective``.

Read by the plan, used by the optimiser: declared here so that ``inputs`` does not import
``optimize``.
"""

from __future__ import annotations

from typing import Literal

#: The largest MRR, or the least Borangiu cost ``J`` (Borangiu et al., the productivity).
Objective = Literal["mrr", "productivity"]
OBJECTIVES: tuple[Objective, ...] = ("mrr", "productivity")
