"""Pydantic models of the REST bodies: they make the OpenAPI document and check responses.

Request bodies are checked again by the domain readers (:mod:`supervisor.inputs.part_report`,
:mod:`supervisor.inputs.plan`), whose errors name the dotted field; these models describe them.
"""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, WithJsonSchema

from models.kinematics import CONTEXT, PARAMETERS, PROCESSES
from models.quantities import DERIVED_QUANTITIES, MODEL_QUANTITIES, PARTS_PER_EDGE
from supervisor.inputs.part_report import MAX_EDGE_PARTS
from supervisor.rcb.strategies import REGISTRY, STRATEGY_NAMES

#: What the docs say of each strategy: its name and summary from the registry.
STRATEGY_DOC = "RCB strategy: " + "; ".join(f"{s.name}: {s.summary}" for s in REGISTRY.values())


def _registered(name: str) -> str:
    if name not in REGISTRY:
        raise ValueError(f"unknown strategy; expected one of: {', '.join(STRATEGY_NAMES)}")
    return name


#: A name of :data:`supervisor.rcb.strategies.REGISTRY`: the OpenAPI enum and the check both come
#: from the registry (never restated here).
Strategy = Annotated[
    str,
    AfterValidator(_registered),
    WithJsonSchema({"type": "string", "enum": list(STRATEGY_NAMES), "description": STRATEGY_DOC}),
]


def _storable(value: str) -> str:
    """Refuse what no database column can hold: NUL, unpaired surrogates (JSON allows both)."""
    if "\x00" in value:
        raise ValueError("must not contain NUL characters")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise ValueError("must be valid Unicode (an unpaired surrogate)") from None
    return value


#: A string with something in it (the domain readers refuse blank text) that can be stored.
Text = Annotated[str, Field(pattern=r"\S"), AfterValidator(_storable)]
#: A path or query value without NUL (PostgreSQL refuses it in a query).
NO_NUL = r"^[^\x00]*$"

#: Quantities a part report may measure: every model quantity but tool life, which follows from
#: ``tool_wear`` (:func:`supervisor.rcb.update.update`; the operation's tool must model it).
MEASURABLE = [q for q in MODEL_QUANTITIES if q != "tool_life_mm3"] + ["spindle_load_V"]


def _keys(names: list[str]) -> dict[str, Any]:
    """JSON Schema of a table whose keys the domain reader checks.

    Documented, not validated here: the reader's error, naming the field and the known keys, is
    what the client sees.
    """
    return {"propertyNames": {"enum": names}}


class _Out(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Problem(BaseModel):
    """RFC 9457 problem details, with the offending field."""

    type: str
    title: str
    status: int
    detail: str
    instance: str | None = None
    code: str = Field(description="machine-readable error code")
    field: str | None = Field(None, description="the offending field, as a dotted path")
    value: Any = Field(None, description="the offending value")
    errors: list[dict[str, Any]] | None = None
    conflicts: list[dict[str, Any]] | None = Field(
        None, description="plan_halted: per operation, the limits that cannot be met"
    )


class Health(_Out):
    """Liveness."""

    status: Literal["ok"]


class Band(_Out):
    """A prediction and its band ± ΔY."""

    value: float
    band: float


class ConstantLoadOut(_Out):
    """Constant-load control of a milling setpoint (Tai et al.): what the inner loop holds."""

    reference_current_A: float = Field(description="spindle current the feed override holds")
    feed_rate_upper_mm_min: float = Field(description="never above the programmed feed rate")
    feed_rate_lower_mm_min: float = Field(description="change the tool when the feed reaches it")
    programmed_feed_rate_mm_min: float
    upper_governed_by: Literal["current", "setpoint"]
    tool_change_by_feed: bool
    wear_interval_mm: tuple[float, float]


class OperationSetpoint(_Out):
    """One operation's setpoint as in ``rcb optimize --json``."""

    name: str
    tool: str
    process: str
    setpoint: dict[str, float]
    predicted: dict[str, Band]
    mrr_cm3_min: float
    time_min: float
    binding: list[str]
    objective: Literal["mrr", "productivity"] = "mrr"
    cost_per_kg: float | None = Field(
        None, description="Borangiu's productivity cost J, when the operation has cost data"
    )
    constant_load: ConstantLoadOut | None = None
    robust_by: Literal["band", "cone"] = Field(
        "band",
        description="what keeps the setpoint safe: the bands, or (strategy learn) the learned "
        "model's cone; with cone, predicted shows the learned value and the cone's half-width",
    )


class PlanCreated(_Out):
    """A new plan and its first setpoints."""

    id: int
    name: str
    setpoint_version: int
    operations: list[OperationSetpoint]


class Setpoints(_Out):
    """The setpoints in force."""

    plan_id: int
    setpoint_version: int
    operations: list[OperationSetpoint]


class MeasurementIn(BaseModel):
    """A measured value and its (expanded) uncertainty, in the quantity's unit."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    value: float = Field(ge=0)
    uncertainty: float = Field(ge=0)


class ReadingIn(MeasurementIn):
    """A measurement, or a raw spindle reading the machine's calibration converts to force_N.

    The optional fields are for ``spindle_load_V`` and ``spindle_current_A`` readings only:
    what the conversion needs and the setpoint does not say (the idle load, a measured speed).
    """

    calibration: Text | None = Field(None, max_length=200, description="machine calibration")
    spindle_speed_rpm: float | None = Field(None, gt=0)
    workpiece_diameter_mm: float | None = Field(None, gt=0)
    u_workpiece_diameter_mm: float | None = Field(None, ge=0)
    idle_load_V: float | None = Field(None, ge=0)
    u_idle_load_V: float | None = Field(None, ge=0)
    feed_rate_mm_min: float | None = Field(None, gt=0)
    u_feed_rate_mm_min: float | None = Field(None, ge=0)


class ToolWearIn(BaseModel):
    """Flank wear of the operation's edge and the volume the edge has cut so far."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    flank_wear_mm: MeasurementIn
    volume_mm3: float = Field(gt=0)


class OperationReport(BaseModel):
    """What was measured on one operation of a part."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    name: Text
    measurements: dict[str, ReadingIn] = Field(
        default_factory=dict,
        description="per quantity the operation's tool models (tool life: ``tool_wear``), "
        "or a spindle reading converted to force_N by the machine's calibration",
        json_schema_extra=_keys(MEASURABLE),
    )
    tool_wear: ToolWearIn | None = None
    feed_override_percent: float | None = Field(
        None,
        gt=0,
        description="constant-load operations: the feed override at the end of the operation, "
        "% of the programmed feed; at the lower feed limit the tool is due for a change",
    )
    edge_parts: int | None = Field(
        None,
        ge=0,
        le=MAX_EDGE_PARTS,
        description="parts the operation's cutting edge made before this one (0: a new edge), "
        "as the control's tool-life counter gives it; the learn strategy learns wear from it",
    )


class PartReportIn(BaseModel):
    """A part report from the MES."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    serial: Text = Field(max_length=200)
    setpoint_version: int = Field(ge=1)
    operations: list[OperationReport]


class Update(_Out):
    """What one measurement did to one band."""

    operation: str
    quantity: str
    action: Literal["shrink", "hold", "expand"]
    margin: float | None
    band_before: float
    band_after: float
    predicted: float | None = None
    measured: float | None = None
    flagged: bool = Field(description="flag is not null (kept for compatibility)")
    flag: Literal["breach", "above_band", "below_band"] | None = Field(
        None,
        description="why the decision is flagged: breach (past the limit), or past the band's "
        "guarding edge (above_band for a maximum, below_band for a minimum); the band grew",
    )
    note: Literal["below_band", "above_band"] | None = Field(
        None,
        description="information only, never a flag: past the band's other edge (below_band "
        "for a maximum: the model is pessimistic there)",
    )
    reason: str


class ToolChangeOut(_Out):
    """A reported feed override of a constant-load operation, and whether the tool is due."""

    operation: str
    feed_override_percent: float
    commanded_feed_rate_mm_min: float
    feed_rate_lower_mm_min: float
    due: bool
    reason: str


class ConflictOut(_Out):
    """A limit that cannot be met, and what it would have to be."""

    name: str
    limit: float
    required: float = Field(description="the least demanding limit the rest allows")
    sense: Literal["max", "min"]


class HaltedOperationOut(_Out):
    """An operation no setpoint can run under the bands in force."""

    operation: str
    message: str
    conflicts: list[ConflictOut]
    held_by: list[str] = Field(description="the other limits and bounds tight at the closest point")


class HaltOut(_Out):
    """Why a plan halted."""

    message: str
    conflicts: list[HaltedOperationOut]


class PartCreated(_Out):
    """The part stored, what RCB did, the tool changes due, and the setpoints now in force.

    ``halted``: the bands leave no safe setpoint; the part is stored, the setpoints shown are
    those it was made with, and ``GET .../setpoints`` answers 409 ``plan_halted`` until a
    replan.
    """

    part_id: int
    serial: str
    setpoint_version: int
    halted: bool = False
    conflicts: list[HaltedOperationOut] = Field(default_factory=list)
    updates: list[Update]
    tool_changes: list[ToolChangeOut] = Field(default_factory=list)
    operations: list[OperationSetpoint]


class MeasurementOut(_Out):
    """A stored measurement; ``raw``: the spindle reading it was converted from, if any."""

    value: float
    uncertainty: float
    raw: dict[str, Any] | None = None


class ToolWearOut(_Out):
    """A stored flank-wear measurement."""

    flank_wear_mm: MeasurementOut
    volume_mm3: float | None


class PartOperation(_Out):
    """One operation of a stored part."""

    name: str
    measurements: dict[str, MeasurementOut]
    tool_wear: ToolWearOut | None = None


class PartOut(_Out):
    """A stored part."""

    part_id: int
    serial: str
    setpoint_version: int
    received_at: datetime
    operations: list[PartOperation]
    updates: list[Update]


class PartsPage(_Out):
    """A page of parts; pass ``next_cursor`` as ``cursor`` for the next (null: no more)."""

    items: list[PartOut]
    next_cursor: str | None


class RcbSettingsOut(_Out):
    """The plan's RCB settings beyond strategy and alpha."""

    floors: dict[str, float] = Field(description="least band per quantity; default: the u")
    coverage_k: float
    discrepancy: float
    z: float
    exponent_sd: float
    edge_sd: float


class PlanSummary(_Out):
    """A plan in a list."""

    id: int
    name: str
    machine: str
    strategy: Strategy
    alpha: float
    settings: RcbSettingsOut
    status: Literal["running", "halted"]
    halt: HaltOut | None = None
    setpoint_version: int
    parts: int
    created_at: datetime


class PlanList(_Out):
    """Every plan."""

    plans: list[PlanSummary]


class PlanOperation(_Out):
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
    operations: list[PlanOperation]
    body: dict[str, Any]


class ModelInForce(_Out):
    """A model version of one operation and quantity."""

    K: float
    dK: float
    version: int


class HistoryOperation(_Out):
    """One operation in a setpoint version, with the models in force."""

    name: str
    tool: str
    setpoint: dict[str, float]
    predicted: dict[str, Band]
    mrr_cm3_min: float
    time_min: float
    binding: list[str]
    models: dict[str, ModelInForce]


class HistoryVersion(_Out):
    """One setpoint version and its cause (``initial``, ``part`` with the serial, ``replan``)."""

    version: int
    cause: str
    part_id: int | None
    serial: str | None
    created_at: datetime
    cycle_time_min: float
    operations: list[HistoryOperation]


class History(_Out):
    """Every setpoint version of a plan, oldest first; whether it is halted now, and why."""

    plan_id: int
    status: Literal["running", "halted"] = "running"
    halt: HaltOut | None = None
    versions: list[HistoryVersion]


class ModelVersion(_Out):
    """A stored model version."""

    version: int
    K: float
    dK: float
    exponents: dict[str, float]
    cause: str
    serial: str | None
    created_at: datetime


class OperationModels(_Out):
    """The models in force for one operation."""

    name: str
    tool: str
    models: dict[str, ModelVersion]


class PlanModels(_Out):
    """The models in force, per operation and quantity."""

    plan_id: int
    operations: list[OperationModels]


class ModelVersionRow(ModelVersion):
    """A model version with its operation and quantity."""

    operation: str
    quantity: str


class ModelVersions(_Out):
    """Model versions, oldest first."""

    plan_id: int
    versions: list[ModelVersionRow]


class ModelIn(BaseModel):
    """A power-law model ``Y = K·Π x_i^e_i`` with band ±ΔK."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    K: float = Field(gt=0)
    dK: float = Field(0.0, ge=0)
    exponents: dict[str, float] = Field(
        default_factory=dict,
        description="per variable of the tool's process: its parameters and context",
        json_schema_extra=_keys(sorted({v for p in PROCESSES for v in PARAMETERS[p] + CONTEXT[p]})),
    )
    source: Text | None = Field(None, description="default: the tool's source")
    reference: Text | None = Field(None, description="where in the source (table, equation)")
    exponent_stderr: dict[str, float] | None = Field(
        None,
        description="standard errors of fitted exponents (rcb fit); learn's prior spread",
    )


def _exponents_of_process(schema: dict[str, Any]) -> None:
    """A model's exponents may only name the variables of the tool's own process."""
    schema["allOf"] = [
        {
            "if": {"properties": {"process": {"const": p}}},
            "then": {
                "properties": {
                    "models": {
                        "additionalProperties": {
                            "properties": {"exponents": _keys(list(PARAMETERS[p] + CONTEXT[p]))}
                        }
                    }
                }
            },
        }
        for p in PROCESSES
    ]


class ToolIn(BaseModel):
    """A tool with its models, as in a plan file's ``[[tools]]``."""

    model_config = ConfigDict(
        extra="forbid", allow_inf_nan=False, json_schema_extra=_exponents_of_process
    )
    name: Text = Field(max_length=200)
    process: Literal["turning", "milling"]
    description: Text | None = None
    material: Text | None = None
    source: Text | None = Field(None, description="where the models come from (default: REST API)")
    models: dict[str, ModelIn] = Field(
        min_length=1, json_schema_extra=_keys(list(MODEL_QUANTITIES))
    )


class ModelOut(_Out):
    """A baseline model with provenance."""

    K: float
    dK: float
    exponents: dict[str, float]
    source: str
    reference: str


class ToolOut(_Out):
    """A tool with its baseline models and provenance."""

    name: str
    process: str
    description: str
    material: str
    source: str
    models: dict[str, ModelOut]


class ToolList(_Out):
    """The catalogue and the stored tools."""

    tools: list[ToolOut]


#: What an operation's ``limits`` may name: maxima of the models, the machine quantities, and
#: the tool-life minimum ``parts_per_edge`` (supervisor.inputs.plan).
LIMITS = [q for q, info in MODEL_QUANTITIES.items() if info.sense == "max"]
LIMITS += [*DERIVED_QUANTITIES, PARTS_PER_EDGE]
_ALL_PARAMETERS = sorted({v for p in PROCESSES for v in PARAMETERS[p]})


class MachineIn(BaseModel):
    """The machine and its limits (omitted: no limit)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    name: Text = Field(max_length=200)
    max_power_kW: float | None = Field(None, gt=0)
    max_spindle_rpm: float | None = Field(None, gt=0)
    max_torque_Nm: float | None = Field(None, gt=0)
    max_feed_rate_mm_min: float | None = Field(None, gt=0)
    calibrations: dict[str, dict[str, Any]] | None = Field(
        None,
        description="named sensor calibrations, each a table with a `kind` "
        "(ivester_spindle_load, linear_current, linear_current_by_feed, tai_current_feed) "
        "and its constants and provenance, as in a plan file (models.sensors)",
    )


class OperationIn(BaseModel):
    """One operation of a plan, as in a plan file's ``[[operations]]``."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    name: Text = Field(max_length=200)
    process: Literal["turning", "milling"] | None = Field(None, description="default: the tool's")
    tool: Text = Field(max_length=200, description="a catalogue, stored or inline tool")
    description: Text | None = None
    volume_mm3: float = Field(gt=0, description="material the operation removes")
    limits: dict[str, float] = Field(
        default_factory=dict,
        description="maxima of predicted quantities, and parts_per_edge (a minimum)",
        json_schema_extra=_keys(LIMITS),
    )
    bounds: dict[str, tuple[float, float]] = Field(
        description="[low, high] of every cutting parameter of the process",
        json_schema_extra=_keys(_ALL_PARAMETERS),
    )
    workpiece_diameter_mm: float | None = Field(None, gt=0, description="turning")
    tool_diameter_mm: float | None = Field(None, gt=0, description="milling")
    flute_count: int | None = Field(None, ge=1, description="milling")
    allowable_flank_wear_mm: float | None = Field(None, gt=0, description="default 0.3 (ISO 3685)")
    setpoint_rel_uncertainty: dict[str, float] | None = Field(
        None,
        description="relative setpoint uncertainties Δx/x",
        json_schema_extra=_keys(_ALL_PARAMETERS),
    )
    catalog_setpoint: dict[str, float] | None = Field(
        None, description="the shop's current parameters", json_schema_extra=_keys(_ALL_PARAMETERS)
    )
    objective: Literal["mrr", "productivity"] | None = Field(
        None, description="max MRR (default) or Borangiu's least productivity cost J (milling)"
    )
    productivity: dict[str, float] | None = Field(
        None, description="cost data of J (Borangiu Eq. 1, Taylor's law), as in a plan file"
    )
    domain: dict[str, float] | None = Field(
        None, description="Borangiu's Eqs. 2-7 constraints (milling), as in a plan file"
    )
    constant_load: dict[str, Any] | None = Field(
        None,
        description="constant-load control (Tai et al., milling): calibration (a "
        "tai_current_feed calibration of the machine), max_current_A, safety_factor, "
        "wear_interval_um",
    )


class PlanIn(BaseModel):
    """A plan: the structure of a plan file, as JSON."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    name: Text = Field(max_length=200)
    description: Text | None = None
    machine: MachineIn
    tools: list[ToolIn] | None = Field(None, description="inline tools (else catalogue or stored)")
    operations: list[OperationIn] = Field(min_length=1)


class ModelChangeIn(BaseModel):
    """New K and/or ΔK of a model in force (exponents stay)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    K: float | None = Field(None, gt=0)
    dK: float | None = Field(None, ge=0)


class ReplanIn(BaseModel):
    """An engineer's change (supervisor.rcb.replan)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    limits: dict[str, float | None] | None = Field(
        None, description="OPERATION.QUANTITY -> new limit (null: remove it)"
    )
    bounds: dict[str, tuple[float, float]] | None = Field(
        None, description="OPERATION.PARAMETER -> [low, high]"
    )
    models: dict[str, ModelChangeIn] | None = Field(
        None, description="TOOL.QUANTITY -> {K, dK} in every operation using the tool"
    )
    reset_bands: bool | None = Field(None, description="back to the tools' baseline bands")


class SetpointChange(_Out):
    """One operation's setpoint before and after."""

    operation: str
    setpoint: dict[str, list[float | None]]
    mrr_cm3_min: list[float]
    binding: list[list[str]]


class Replanned(_Out):
    """The replan: the difference to the setpoints in force, and the new setpoints."""

    plan_id: int
    dry_run: bool
    setpoint_version: int
    reset_bands: bool
    cycle_time_min: list[float]
    diff: list[SetpointChange]
    operations: list[OperationSetpoint]
