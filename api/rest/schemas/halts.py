"""Why a plan halted: the operations no setpoint can run, and the limits that cannot be met."""

from __future__ import annotations

from pydantic import Field

from api.rest.schemas.common import Out
from models.quantities import Sense


class ConflictOut(Out):
    """A limit that cannot be met, and what it would have to be."""

    name: str
    limit: float
    required: float = Field(description="the least demanding limit the rest allows")
    sense: Sense


class HaltedOperationOut(Out):
    """An operation the plan halted on.

    No setpoint can run it under the bands in force (``conflicts``), or a reading was past its
    limit by more than the plan's ``halt_over`` (``conflicts`` and ``held_by`` empty,
    ``message`` names the reading, its limit and by how much).
    """

    operation: str
    message: str
    conflicts: list[ConflictOut] = Field(
        description="the limits that cannot all be met; empty for a gross breach"
    )
    held_by: list[str] = Field(description="the other limits and bounds tight at the closest point")


class HaltOut(Out):
    """Why a plan halted: the bands leave no setpoint, or a reading past halt_over."""

    message: str
    conflicts: list[HaltedOperationOut]
