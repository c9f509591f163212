"""Plans: the plan-file structure as JSON, a new plan's answer, a plan as listed and read."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, create_model

from api.rest.schemas.common import Name, Number, Out, Positive, Strategy, Text, keys_schema
from api.rest.schemas.halts import HaltOut
from api.rest.schemas.rcb_settings import RcbSettingsIn, RcbSettingsOut
from api.rest.schemas.setpoints import (
    NoiseProvenances,
    OperationSetpoint,
    PriorSource,
    Provenances,
)
from api.rest.schemas.tools import ToolIn
from models.bounds import (
    MAX_CALIBRATIONS,
    MAX_FLUTES,
    MAX_OPERATIONS,
    MAX_TABLE_KEYS,
    MAX_TOOLS,
)
from models.kinematics import PARAMETERS, PROCESSES, Process
from models.quantities import limit_keys, machine_fields
from supervisor.inputs.objectives import Objective


class PlanCreated(Out):
    """A new plan and its first setpoints."""

    id: int
    name: str
    setpoint_version: int
    cycle_time_min: float = Field(description="the machining time of one part at version 1")
    prior: PriorSource
    provenance: Provenances
    noise_provenance: NoiseProvenances
    fleet_out: str | None = Field(
        None,
        description="the plan's machine is taken out of the fleet by an engineer: what GET "
        "/plans/{id} says in its fleet_out (who, and the reason); its readings make no new "
        "plan's prior until the machine is put back (null: not taken out, or the plan's "
        "strategy learns no posterior)",
    )
    operations: list[OperationSetpoint]


class PlanSummary(Out):
    """A plan in a list."""

    id: int
    name: str
    machine: str
    strategy: Strategy
    alpha: float
    settings: RcbSettingsOut
    status: Literal["running", "halted"]
    halt: HaltOut | None = None
    settings_refused: str | None = Field(
        None,
        description="a stored setting this version's check refuses (stored under an earlier "
        "one): which, and the replan that sets it anew; its part reports are 409 "
        "stored_settings_refused until then (null: none)",
    )
    setpoint_version: int
    parts: int
    created_at: datetime


class PlanList(Out):
    """A page of plans by id (a key scoped to plans: those only).

    Pass ``next_cursor`` as ``cursor`` for the next page; null: no more.
    """

    plans: list[PlanSummary]
    next_cursor: str | None


class PlanOperation(Out):
    """An operation's definition."""

    name: str
    tool: str
    process: str
    volume_mm3: float
    limits: dict[str, float]
    bounds: dict[str, list[float]]
    context: dict[str, float]


class PlanDetail(PlanSummary):
    """A plan with its machine limits, operations and the structure it was created from."""

    machine_limits: dict[str, float | None]
    prior: PriorSource
    provenance: Provenances
    noise_provenance: NoiseProvenances
    operations: list[PlanOperation]
    body: dict[str, Any]
    plan_refused: str | None = Field(
        None,
        description="a stored field of the plan, or a model of a stored tool it uses, that this "
        "version's check refuses (stored under an earlier one): which, and the way to set it "
        "anew; its part reports are 409 until then (null: none)",
    )
    fleet_out: str | None = Field(
        None,
        description="why none of the plan's learned models make a new plan's fleet prior: an "
        "engineer took the plan or its machine out (who, and the reason), it is halted, its "
        "strategy learns none, or its process changed beyond what an engineer accepted (null: "
        "none of these; GET /tools/{name}/fleet says per tool)",
    )


#: What an operation's ``limits`` may name (the quantity registry, models.quantities): maxima
#: of the models, the machine quantities, and the tool-life minimum ``parts_per_edge``.
LIMITS = list(limit_keys())
_ALL_PARAMETERS = sorted({v for p in PROCESSES for v in PARAMETERS[p]})


#: The machine's name and a field per machine limit of the quantity registry
#: (:attr:`models.quantities.Quantity.machine_field`, ``max_power_kW`` ...), in that order.
_MachineLimits: type[BaseModel] = create_model(
    "_MachineLimits",
    __config__=ConfigDict(extra="forbid", allow_inf_nan=False),
    name=(Name, ...),
    **dict.fromkeys(machine_fields(), (Positive | None, None)),  # type: ignore[call-overload]
)


class MachineIn(_MachineLimits):  # type: ignore[misc,valid-type]
    """The machine and its limits (omitted: no limit)."""

    calibrations: dict[Name, dict[str, Any]] | None = Field(
        None,
        max_length=MAX_CALIBRATIONS,
        description="named sensor calibrations, each a table with a `kind` "
        "(ivester_spindle_load, linear_current, linear_current_by_feed, tai_current_feed) "
        "and its constants and provenance, as in a plan file (models.sensors)",
    )
    resolution: dict[str, Positive] | None = Field(
        None,
        description="the step of each cutting parameter the control takes, in its unit "
        "(default: depths 0.001 mm, feed_mm_rev 0.0001, speed_m_min 1, feed_per_tooth_mm "
        "0.0001); setpoints lie on this grid (supervisor.inputs.resolution)",
        json_schema_extra=keys_schema(_ALL_PARAMETERS),
    )


class OperationIn(BaseModel):
    """One operation of a plan, as in a plan file's ``[[operations]]``."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    name: Name
    process: Process | None = Field(None, description="default: the tool's")
    tool: Name = Field(description="a catalogue, stored or inline tool")
    description: Text | None = None
    volume_mm3: Positive = Field(description="material the operation removes")
    limits: dict[str, Positive] = Field(
        default_factory=dict,
        description="maxima of predicted quantities, and parts_per_edge (a minimum)",
        json_schema_extra=keys_schema(LIMITS),
    )
    bounds: dict[str, tuple[Positive, Positive]] = Field(
        description="[low, high] of every cutting parameter of the process",
        json_schema_extra=keys_schema(_ALL_PARAMETERS),
    )
    workpiece_diameter_mm: Positive | None = Field(None, description="turning")
    tool_diameter_mm: Positive | None = Field(None, description="milling")
    flute_count: Annotated[int, Field(strict=True, ge=1, le=MAX_FLUTES)] | None = Field(
        None, description="milling"
    )
    allowable_flank_wear_mm: Positive | None = Field(None, description="default 0.3 (ISO 3685)")
    setpoint_rel_uncertainty: dict[str, Number] | None = Field(
        None,
        description="relative setpoint uncertainties Δx/x",
        json_schema_extra=keys_schema(_ALL_PARAMETERS),
    )
    catalog_setpoint: dict[str, Number] | None = Field(
        None,
        description="the shop's current parameters",
        json_schema_extra=keys_schema(_ALL_PARAMETERS),
    )
    objective: Objective | None = Field(
        None, description="max MRR (default) or Borangiu's least productivity cost J (milling)"
    )
    productivity: dict[str, Number] | None = Field(
        None, description="cost data of J (Borangiu Eq. 1, Taylor's law), as in a plan file"
    )
    domain: dict[str, Number] | None = Field(
        None, description="Borangiu's Eqs. 2-7 constraints (milling), as in a plan file"
    )
    constant_load: dict[str, Any] | None = Field(
        None,
        max_length=MAX_TABLE_KEYS,
        description="constant-load control (Tai et al., milling): calibration (a "
        "tai_current_feed calibration of the machine), max_current_A, safety_factor, "
        "wear_interval_um",
    )
    stock_mm: Positive | None = Field(
        None,
        description="stock to remove in whole passes (turning: radial, milling: axial); the "
        "optimiser chooses the count and depth of the passes; the depth bound becomes optional",
    )
    finish: dict[str, Any] | None = Field(
        None,
        max_length=2,
        description="with stock_mm, a finishing pass: its depth (depth_mm, milling "
        "axial_depth_mm) and limits added to the operation's for that pass",
    )


class PlanIn(BaseModel):
    """A plan: the structure of a plan file, as JSON."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    name: Name
    description: Text | None = None
    machine: MachineIn
    tools: list[ToolIn] | None = Field(
        None, max_length=MAX_TOOLS, description="inline tools (else catalogue or stored)"
    )
    operations: list[OperationIn] = Field(min_length=1, max_length=MAX_OPERATIONS)
    rcb: RcbSettingsIn | None = Field(
        None, description="the plan's RCB settings (the query parameters take precedence)"
    )


#: The create route's example: the rough OD of Ivester & Heigel's demonstration part.
PLAN_EXAMPLE = {
    "one operation": {
        "summary": "Rough OD of Ivester & Heigel's demonstration part (Table 4 step 1)",
        "value": {
            "name": "demo-rough-od",
            "machine": {"name": "lathe-22kW", "max_power_kW": 22},
            "operations": [
                {
                    "name": "rough-od",
                    "tool": "CNMG432RN",
                    "workpiece_diameter_mm": 60,
                    "volume_mm3": 86400,
                    "limits": {"force_N": 2000, "roughness_um": 4.0},
                    "bounds": {
                        "depth_mm": [0.5, 3.0],
                        "feed_mm_rev": [0.1, 0.6],
                        "speed_m_min": [100, 200],
                    },
                }
            ],
        },
    }
}
