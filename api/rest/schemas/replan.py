"""An engineer's replan: the change, and the setpoints before and after."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field, StrictBool

from api.rest.schemas.common import NonNegative, Out, Positive
from api.rest.schemas.rcb_settings import RcbSettingsIn
from api.rest.schemas.setpoints import OperationSetpoint
from db.fleet_exclusions import MAX_REASON


class ModelChangeIn(BaseModel):
    """New K and/or ΔK of a model in force (exponents stay)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    K: Positive | None = None
    dK: NonNegative | None = None


class ReplanIn(BaseModel):
    """An engineer's change (supervisor.rcb.replan)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    limits: dict[str, Positive | None] | None = Field(
        None, description="OPERATION.QUANTITY -> new limit (null: remove it)"
    )
    bounds: dict[str, tuple[Positive, Positive]] | None = Field(
        None, description="OPERATION.PARAMETER -> [low, high]"
    )
    models: dict[str, ModelChangeIn] | None = Field(
        None, description="TOOL.QUANTITY -> {K, dK} in every operation using the tool"
    )
    reset_bands: StrictBool | None = Field(None, description="back to the tools' baseline bands")
    rcb: RcbSettingsIn | None = Field(None, description="new RCB settings (the others stay)")
    reason: str | None = Field(
        None,
        min_length=1,
        description=f"why (no change itself): kept in the replan's audit entry, detail "
        f"{{reason}} (rcb audit --plan); 1 to {MAX_REASON} printable characters once stripped, "
        "as a fleet exclusion's reason",
    )


class SetpointChange(Out):
    """One operation's setpoint before and after."""

    operation: str
    setpoint: dict[str, list[float | None]]
    mrr_cm3_min: list[float]
    binding: list[list[str]]


class Replanned(Out):
    """The replan: the difference to the setpoints in force, and the new setpoints."""

    plan_id: int
    dry_run: bool
    setpoint_version: int
    reset_bands: bool
    cycle_time_min: list[float]
    diff: list[SetpointChange]
    operations: list[OperationSetpoint]
