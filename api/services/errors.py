"""Errors of the use cases that are not the input's: a stored object missing, a plan halted."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any


class NotFoundError(LookupError):
    """No such plan (or other stored object)."""

    def __init__(self, field: str, value: object) -> None:
        self.field, self.value = field, value
        super().__init__(f"{field} = {value!r}: not found")


class PlanHaltedError(Exception):
    """The plan is halted (no setpoint meets its bands, or a reading past ``halt_over``).

    Setpoints are refused until an engineer replans; ``conflicts``: per halted operation, as
    stored (:mod:`db.plan_state`).
    """

    def __init__(self, plan_id: int, halt: Mapping[str, Any]) -> None:
        self.field, self.value = "plan_id", plan_id
        self.conflicts: list[dict[str, Any]] = list(halt.get("conflicts", []))
        super().__init__(
            f"plan {plan_id} is halted: {halt.get('message', '')}; "
            "replan it (rcb replan or POST .../replan) to resume"
        )
