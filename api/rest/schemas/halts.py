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
    """An operation no setpoint can run under the bands in force."""

    operation: str
    message: str
    conflicts: list[ConflictOut]
    held_by: list[str] = Field(description="the other limits and bounds tight at the closest point")


class HaltOut(Out):
    """Why a plan halted."""

    message: str
    conflicts: list[HaltedOperationOut]
