"""What engineers review: setpoint versions with the models in force, model versions."""

from __future__ import annotations

from datetime import datetime
from typing import Literal

from pydantic import Field

from api.rest.schemas.common import Out
from api.rest.schemas.halts import HaltOut
from api.rest.schemas.setpoints import Predicted, Setpoint


class ModelInForce(Out):
    """A model version of one operation and quantity."""

    K: float
    dK: float
    version: int


class HistoryOperation(Out):
    """One operation in a setpoint version, with the models in force."""

    name: str
    tool: str
    setpoint: Setpoint
    predicted: Predicted
    mrr_cm3_min: float
    time_min: float
    binding: list[str]
    models: dict[str, ModelInForce]


class HistoryVersion(Out):
    """One setpoint version and its cause (``initial``, ``part`` with the serial, ``replan``)."""

    version: int
    cause: str
    actor: str | None = Field(
        None, description="who made a replan: `key:ID` (REST) or `cli:NAME` (rcb replan --by)"
    )
    part_id: int | None
    serial: str | None
    created_at: datetime
    cycle_time_min: float
    operations: list[HistoryOperation]


class History(Out):
    """A page of a plan's setpoint versions, oldest first; whether it is halted now, and why.

    Pass ``next_cursor`` as ``cursor`` (with the same ``order``) for the next page; null: no more.
    """

    plan_id: int
    status: Literal["running", "halted"] = "running"
    halt: HaltOut | None = None
    versions: list[HistoryVersion]
    next_cursor: str | None = None


class ModelVersion(Out):
    """A stored model version."""

    version: int
    K: float
    dK: float
    exponents: dict[str, float]
    cause: str
    serial: str | None
    created_at: datetime


class OperationModels(Out):
    """The models in force for one operation."""

    name: str
    tool: str
    models: dict[str, ModelVersion]


class PlanModels(Out):
    """The models in force, per operation and quantity."""

    plan_id: int
    operations: list[OperationModels]


class ModelVersionRow(ModelVersion):
    """A model version with its operation and quantity."""

    operation: str
    quantity: str


class ModelVersions(Out):
    """A page of model versions by version, then operation (plan order), then quantity.

    Pass ``next_cursor`` as ``cursor`` (with the same filters) for the next page; null: no more.
    """

    plan_id: int
    versions: list[ModelVersionRow]
    next_cursor: str | None
