"""Part reports: what the MES sends after a part, what RCB did, and the stored parts."""

from __future__ import annotations

from datetime import datetime
from typing import TYPE_CHECKING, Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, ValidationInfo, field_validator

from api.rest.schemas.common import (
    Count,
    Name,
    NonNegative,
    Out,
    Positive,
    field_path,
    plain_message,
)
from api.rest.schemas.halts import HaltedOperationOut
from api.rest.schemas.quantities import keyed_table
from api.rest.schemas.setpoints import OperationSetpoint
from api.services.read.record import TOOL_CHANGE
from models.bounds import LARGEST, MAX_EDGE_PARTS, MAX_OPERATIONS, SMALLEST_MEASURED
from models.errors import InputError
from models.quantities import MODEL_QUANTITIES, QUANTITIES
from supervisor.inputs.part_report import (
    SIGNAL_CONTEXT,
    Measurement,
    PartReport,
    Signal,
    ToolWear,
)
from supervisor.rcb.decision import Action, Flag, Note

#: Quantities a part report may measure: every model quantity but tool life, which follows from
#: ``tool_wear`` (:func:`supervisor.rcb.update.update`; the operation's tool must model it).
MEASURABLE = [q for q in MODEL_QUANTITIES if q != "tool_life_mm3"] + ["spindle_load_V"]
#: What a stored part's measurements may hold: the measurable quantities (a spindle reading as
#: converted), a constant-load operation's feed override (api.services.read.record.TOOL_CHANGE),
#: and tool life as a report gave it directly before 2026-12-03 (now refused: ``tool_wear``).
STORED = [*MEASURABLE, TOOL_CHANGE, "tool_life_mm3"]
_RAW = "the machine's calibration converts it to force_N"
#: The quantities a raw spindle reading (calibration, context) may be given for.
RAW_READINGS = ("spindle_load_V", "spindle_current_A")
#: The context fields each raw reading's conversion reads (models.sensors.convert): the spindle
#: load's (Ivester & Heigel) the speed, the diameter and the idle load; the current's (Kim &
#: Jeon) the speed and the feed rate. Another is refused: it would be ignored. A load reading
#: also takes the pass's feed rate, which the conversion does not read: ``rcb collect`` sends
#: the machine's (supervisor.collect.report), and the reading's record keeps it.
READING_FIELDS = {
    "spindle_load_V": (
        "spindle_speed_rpm",
        "feed_rate_mm_min",
        "u_feed_rate_mm_min",
        "workpiece_diameter_mm",
        "u_workpiece_diameter_mm",
        "idle_load_V",
        "u_idle_load_V",
    ),
    "spindle_current_A": ("spindle_speed_rpm", "feed_rate_mm_min", "u_feed_rate_mm_min"),
}


def _measured(name: str) -> str:
    if name == TOOL_CHANGE:
        return (
            "the reported feed override [%] (uncertainty 0); raw: the commanded feed rate, its "
            "lower limit and whether the tool was due for a change"
        )
    if name not in QUANTITIES:
        return f"spindle load reading [V]; {_RAW}"
    q = QUANTITIES[name]
    raw = f"; or a raw reading {_RAW}" if name == "spindle_current_A" else ""
    return f"{q.description} [{q.unit}]{raw}"


#: A measured value or its uncertainty: > 0 (SMALLEST_MEASURED), finite, at most LARGEST.
Measured = Annotated[
    float, Field(strict=True, allow_inf_nan=False, ge=SMALLEST_MEASURED, le=LARGEST)
]
#: Parts an edge made before this one.
EdgeParts = Annotated[int, Field(strict=True, ge=0, le=MAX_EDGE_PARTS)]


class MeasurementIn(BaseModel):
    """A measured value and its (expanded) uncertainty, in the quantity's unit.

    What a machine can measure: a value > 0 and an uncertainty > 0 and below the value.
    """

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    value: Measured
    uncertainty: Measured = Field(
        description=(
            "> 0 and < value, expanded (k = 2); RCB counts at least 0.05 % of the value "
            "(LEAST_REL_UNCERTAINTY: no chain reads a cut closer)"
        )
    )

    @field_validator("uncertainty")
    @classmethod
    def _below_value(cls, uncertainty: float, info: ValidationInfo) -> float:
        value = info.data.get("value")
        if value is not None and uncertainty >= value:
            raise ValueError(f"must be less than the value {value:g}")
        return uncertainty


class ReadingIn(MeasurementIn):
    """A measurement, or a raw spindle reading the machine's calibration converts to force_N.

    The optional fields are for ``spindle_load_V`` and ``spindle_current_A`` readings only:
    what the conversion needs and the setpoint does not say (the idle load, a measured speed).
    """

    calibration: Name | None = Field(None, description="machine calibration")
    spindle_speed_rpm: Positive | None = None
    workpiece_diameter_mm: Positive | None = None
    u_workpiece_diameter_mm: NonNegative | None = None
    idle_load_V: NonNegative | None = None
    u_idle_load_V: NonNegative | None = None
    feed_rate_mm_min: Positive | None = None
    u_feed_rate_mm_min: NonNegative | None = None

    def context(self) -> dict[str, float]:
        """What a raw reading carries for its conversion (``SIGNAL_CONTEXT``), as given."""
        given = ((k, getattr(self, k)) for k in SIGNAL_CONTEXT)
        return {k: v for k, v in given if v is not None}

    def raw_fields(self) -> list[str]:
        """The fields given that only a raw spindle reading takes (empty: a measurement)."""
        return [*sorted(self.context()), *(["calibration"] if self.calibration else [])]


_MEASUREMENTS_DOC = (
    "Per quantity the operation's tool models (tool life: ``tool_wear``), what was measured; "
    "or a spindle reading converted to force_N by the machine's calibration."
)
_STORED_DOC = "Per quantity, what was measured (a spindle reading: as converted, with raw)."


class MeasurementOut(Out):
    """A stored measurement; ``raw``: the spindle reading it was converted from, if any."""

    value: float
    uncertainty: float
    raw: dict[str, Any] | None = None


if TYPE_CHECKING:  # to mypy, maps of names; at run time typed tables built from the registry
    Measurements = dict[str, ReadingIn]
    MeasurementsOut = dict[str, MeasurementOut]
else:
    #: A part report's measurements: a property per measurable quantity.
    Measurements = keyed_table(
        "Measurements", _MEASUREMENTS_DOC, MEASURABLE, ReadingIn, _measured, extra="allow"
    )
    #: A stored part's measurements.
    MeasurementsOut = keyed_table("MeasurementsOut", _STORED_DOC, STORED, MeasurementOut, _measured)


class ToolWearIn(BaseModel):
    """Flank wear of the operation's edge and the volume the edge has cut so far."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    flank_wear_mm: MeasurementIn
    volume_mm3: Positive

    def to_wear(self) -> ToolWear:
        """The domain's :class:`~supervisor.inputs.part_report.ToolWear`."""
        wear = self.flank_wear_mm
        return ToolWear(Measurement(wear.value, wear.uncertainty), self.volume_mm3)


class OperationReport(BaseModel):
    """What was measured on one operation of a part.

    At least one measurement, a tool wear or a feed override (an operation with nothing
    measured is refused, naming its ``measurements``).
    """

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    name: Name
    tool_wear: ToolWearIn | None = None
    feed_override_percent: Positive | None = Field(
        None,
        description="constant-load operations: the feed override at the end of the operation, "
        "% of the programmed feed; at the lower feed limit the tool is due for a change",
    )
    edge_parts: EdgeParts | None = Field(
        None,
        description="parts the operation's cutting edge made before this one (0: a new edge), "
        "as the control's tool-life counter gives it; every strategy learns wear from it (the "
        "margin of a wearing quantity is then that of the edge's last part)",
    )
    # last: its check reads the fields before it
    measurements: Measurements = Field(default_factory=dict, validate_default=True)

    @field_validator("measurements")
    @classmethod
    def _something_measured(cls, measured: Measurements, info: ValidationInfo) -> Measurements:
        given = (info.data.get(k) is not None for k in ("tool_wear", "feed_override_percent"))
        if not measured and not any(given):
            raise ValueError(
                "nothing measured: give a measurement, tool_wear or feed_override_percent"
            )
        for quantity, reading in measured.items():
            raw = reading.raw_fields()
            if raw and quantity not in RAW_READINGS:
                why = f"{quantity}: {', '.join(raw)} only with a raw spindle reading"
                raise ValueError(f"{why} ({' or '.join(RAW_READINGS)})")
        return measured


class PartReportIn(BaseModel):
    """A part report from the MES."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    serial: Name
    setpoint_version: Count
    operations: list[OperationReport] = Field(min_length=1, max_length=MAX_OPERATIONS)

    def to_report(self) -> PartReport:
        """The domain's :class:`~supervisor.inputs.part_report.PartReport`.

        An operation listed twice is refused naming the second by its index
        (``operations[1].name``); as a schema check it named the whole list.
        """
        measurements: dict[str, dict[str, Measurement]] = {}
        signals: dict[str, dict[str, Signal]] = {}
        for i, op in enumerate(self.operations):
            if op.name in measurements:
                first = next(k for k, o in enumerate(self.operations) if o.name == op.name)
                why = f"reported twice: also operations[{first}]"
                raise InputError(f"operations[{i}].name", op.name, why)
            measurements[op.name], raw = {}, {}
            for quantity, reading in op.measurements.items():
                _only_its_fields(f"operations[{i}].measurements.{quantity}", quantity, reading)
                measured = Measurement(reading.value, reading.uncertainty)
                if quantity == "spindle_load_V" or reading.raw_fields():
                    raw[quantity] = Signal(
                        quantity, measured, reading.context(), reading.calibration
                    )
                else:
                    measurements[op.name][quantity] = measured
            if raw:
                signals[op.name] = raw
        return PartReport(
            self.serial,
            self.setpoint_version,
            measurements,
            {op.name: op.tool_wear.to_wear() for op in self.operations if op.tool_wear},
            signals,
            {
                op.name: op.feed_override_percent
                for op in self.operations
                if op.feed_override_percent is not None
            },
            {op.name: op.edge_parts for op in self.operations if op.edge_parts is not None},
        )


def _only_its_fields(path: str, quantity: str, reading: ReadingIn) -> None:
    """Refuse a context field the conversion of a ``quantity`` reading does not read."""
    if quantity not in READING_FIELDS:  # a measurement: raw fields refused by the schema
        return
    takes = READING_FIELDS[quantity]
    for name in sorted(reading.context()):
        if name not in takes:
            known = ", ".join(["calibration", *takes])
            why = f"not a field of a {quantity} reading; it takes: {known}"
            raise InputError(f"{path}.{name}", getattr(reading, name), why)


def parse_report(data: object) -> PartReport:
    """A part report from JSON-like ``data``, checked as the REST service checks its body.

    For the callers that are not the service (the benchmarks, the tests): the first error as an
    :class:`~models.errors.InputError` naming its field (``operations[0].measurements``).
    """
    try:
        return PartReportIn.model_validate(data).to_report()
    except ValidationError as err:
        first = err.errors()[0]
        message = plain_message(first, PartReportIn)
        raise InputError(field_path(first["loc"]), first.get("input"), message) from None


class Update(Out):
    """What one measurement did to one band."""

    operation: str
    quantity: str
    action: Action
    margin: float | None = Field(
        description="limit - (measured + u) for a maximum, (measured - u) - limit for a "
        "minimum; a maximum's reading over its prediction counts u + (measured - predicted), "
        "up to u at the measuring chain's bound noise scale (3.15 u before its noise is "
        "known); with edge_parts, a wearing quantity's reading projected to the edge's last "
        "part (reason gives the projection); null without a limit",
    )
    band_before: float
    band_after: float
    predicted: float | None = Field(
        None,
        description="the model's prediction at the setpoint the part was made with, in the "
        "quantity's unit (null for a decision stored before alembic 0029)",
    )
    measured: float | None = Field(
        None,
        description="the value the decision judged, in the quantity's unit: a spindle reading's "
        "converted force (null for a decision stored before alembic 0029)",
    )
    flagged: bool = Field(description="flag is not null (kept for compatibility)")
    flag: Flag | None = Field(
        None,
        description="why the decision is flagged: breach (measured past the limit by more than "
        "3σ of its noise, σ = u/2), or past the band's guarding edge (above_band for a maximum, "
        "below_band for a minimum); the band grew",
    )
    note: Note | None = Field(
        None,
        description="information only, never a flag: past the band's other edge (below_band "
        "for a maximum: the model is pessimistic there); past_limit (measured past the limit "
        "by more than u, within 3σ: out of tolerance by ISO 14253-1, no process alarm); "
        "implausible_low (far below what the model and its scatter allow: a failing sensor, an "
        "air cut or a broken insert; quarantined: no speed-up from it, learned from only when "
        "the next readings at that setpoint confirm it; the operator should check the sensor "
        "and the tool); regime_change (the process changed, e.g. a new batch or another insert "
        "supplier: the old evidence is discounted and re-learned)",
    )
    reason: str


class ToolChangeOut(Out):
    """A reported feed override of a constant-load operation, and whether the tool is due."""

    operation: str
    feed_override_percent: float
    commanded_feed_rate_mm_min: float
    feed_rate_lower_mm_min: float
    due: bool
    reason: str


class PartCreated(Out):
    """The part stored, what RCB did, the tool changes due, and the setpoints now in force.

    ``halted``: the bands leave no safe setpoint, or a reading is past its limit by more than
    the plan's ``halt_over`` (that operation's entry in ``conflicts`` then has no conflicts of
    its own and its ``message`` names the reading); the part is stored, no new setpoint version
    is made (``setpoint_version`` is the last one in force), no setpoint is handed out
    (``operations`` is empty: no part is to be made until an engineer replans), and ``GET
    .../setpoints`` answers 409 ``plan_halted`` until a replan.
    """

    part_id: int
    serial: str
    setpoint_version: int
    halted: bool = False
    conflicts: list[HaltedOperationOut] = Field(default_factory=list)
    updates: list[Update]
    tool_changes: list[ToolChangeOut] = Field(default_factory=list)
    operations: list[OperationSetpoint] = Field(
        description="The setpoints the next part is made with; empty while the plan is halted"
    )


class ToolWearOut(Out):
    """A stored flank-wear measurement."""

    flank_wear_mm: MeasurementOut
    volume_mm3: float | None


class PartOperation(Out):
    """One operation of a stored part."""

    name: str
    measurements: MeasurementsOut
    tool_wear: ToolWearOut | None = None


class PartOut(Out):
    """A stored part."""

    part_id: int
    serial: str
    setpoint_version: int
    received_at: datetime
    operations: list[PartOperation]
    updates: list[Update]


class PartsPage(Out):
    """A page of parts; pass ``next_cursor`` as ``cursor`` for the next (null: no more)."""

    items: list[PartOut]
    next_cursor: str | None
