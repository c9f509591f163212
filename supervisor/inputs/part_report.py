"""Part reports: what the MES sends after a part, as frozen objects.

A report names the part, the setpoint version it was made with, and per operation the
measured quantities, each with its expanded (±2σ) uncertainty, as Ivester & Heigel Table 5
prints them ("horizontal and vertical bars are ±2σ measurement uncertainties", Fig. 4).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from models import fields
from models.bounds import LARGEST_WHOLE, MAX_EDGE_PARTS, MAX_OPERATIONS, SMALLEST_MEASURED
from models.errors import InputError

#: Coverage factor of a reported (expanded) uncertainty: ``σ = U / 2`` (GUM 6.2-6.3; Ivester &
#: Heigel Table 5's ±2σ).
COVERAGE_FACTOR = 2.0


@dataclass(frozen=True)
class Measurement:
    """A measured value and its expanded uncertainty ``±uncertainty`` (same unit, ≈ 2σ).

    ``σ = uncertainty /`` :data:`COVERAGE_FACTOR`.
    """

    value: float
    uncertainty: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.value) and self.value >= 0):
            raise InputError("value", self.value, "must be a finite number >= 0")
        if not (math.isfinite(self.uncertainty) and self.uncertainty >= 0):
            raise InputError("uncertainty", self.uncertainty, "must be a finite number >= 0")


@dataclass(frozen=True)
class ToolWear:
    """Flank wear of the edge an operation uses, measured after it removed ``volume_mm3``.

    Parameters
    ----------
    flank_wear_mm : Measurement
        Average flank wear VB and its uncertainty [mm] (Ivester & Heigel, "Tool Life Model").
    volume_mm3 : float
        Volume the edge has removed since it was new [mm³].
    """

    flank_wear_mm: Measurement
    volume_mm3: float


@dataclass(frozen=True)
class Signal:
    """A raw spindle reading to be converted to ``force_N`` by a machine calibration.

    Parameters
    ----------
    quantity : str
        ``spindle_load_V`` or ``spindle_current_A`` (:data:`models.sensors.RAW_QUANTITIES`).
    reading : Measurement
        The reading and its expanded uncertainty [V] or [A].
    context : Mapping[str, float]
        What the conversion needs and the report knows better than the setpoint
        (``spindle_speed_rpm``, ``idle_load_V`` ..., :data:`SIGNAL_CONTEXT`).
    calibration : str or None
        Name of the machine calibration to use; None: the machine's only one for the quantity.
    """

    quantity: str
    reading: Measurement
    context: Mapping[str, float] = field(default_factory=dict)
    calibration: str | None = None


#: What a raw reading may carry besides value and uncertainty (:func:`models.sensors.to_force`).
SIGNAL_CONTEXT = (
    "spindle_speed_rpm",
    "workpiece_diameter_mm",
    "u_workpiece_diameter_mm",
    "idle_load_V",
    "u_idle_load_V",
    "feed_rate_mm_min",
    "u_feed_rate_mm_min",
)


@dataclass(frozen=True)
class PartReport:
    """What the MES reports after one part.

    Parameters
    ----------
    serial : str
        Part serial number.
    setpoint_version : int
        The setpoint version the part was made with.
    measurements : Mapping[str, Mapping[str, Measurement]]
        Per operation name, the measured quantities (``force_N``, ``roughness_um`` ...).
    tool_wear : Mapping[str, ToolWear]
        Per operation name, a flank-wear measurement of its edge, when one was taken.
    signals : Mapping[str, Mapping[str, Signal]]
        Per operation name, raw spindle readings (``spindle_load_V``; ``spindle_current_A``
        with context or a named calibration) that :mod:`supervisor.inputs.signals` converts to
        ``force_N`` before RCB.
    feed_overrides : Mapping[str, float]
        Per operation name under constant-load control, the feed override at the end of the
        operation [% of the programmed feed rate] (Tai et al.: the tool is changed when the
        feed it commands falls to the lower feed limit).
    edge_parts : Mapping[str, int]
        Per operation name, the parts its cutting edge made before this one (0: a new edge),
        as a control's tool-life counter gives it; the ``learn`` strategy learns wear from it.
    """

    serial: str
    setpoint_version: int
    measurements: Mapping[str, Mapping[str, Measurement]] = field(default_factory=dict)
    tool_wear: Mapping[str, ToolWear] = field(default_factory=dict)
    signals: Mapping[str, Mapping[str, Signal]] = field(default_factory=dict)
    feed_overrides: Mapping[str, float] = field(default_factory=dict)
    edge_parts: Mapping[str, int] = field(default_factory=dict)


_REPORT_KEYS = ("serial", "setpoint_version", "operations")
_OPERATION_KEYS = ("name", "measurements", "tool_wear", "feed_override_percent", "edge_parts")


def report_from_mapping(data: object) -> PartReport:
    """Read a part report as the MES sends it; every error names the field and its value.

    ``{"serial", "setpoint_version", "operations": [{"name", "measurements": {quantity:
    {"value", "uncertainty"}}, "tool_wear"?: {"flank_wear_mm": {"value", "uncertainty"},
    "volume_mm3"}, "edge_parts"?: n}]}``. Whether the operations and quantities exist in the
    plan is checked by :func:`supervisor.rcb.update.update`, which refuses the whole report before
    applying any of it.
    """
    table = fields.mapping(data, "report")
    fields.only_keys(table, _REPORT_KEYS, "")
    version = _setpoint_version(table.get("setpoint_version"))
    operations = _operation_list(table.get("operations"))
    measurements: dict[str, dict[str, Measurement]] = {}
    signals: dict[str, dict[str, Signal]] = {}
    wear: dict[str, ToolWear] = {}
    overrides: dict[str, float] = {}
    edges: dict[str, int] = {}
    for i, entry in enumerate(operations):
        path = f"operations[{i}]"
        op = fields.mapping(entry, path)
        fields.only_keys(op, _OPERATION_KEYS, path)
        name = _identifier(op, "name", path)
        if name in measurements:
            raise InputError(f"{path}.name", name, "operation reported twice")
        measured = fields.mapping(op.get("measurements", {}), f"{path}.measurements")
        measurements[name], signals[name] = {}, {}
        for q, m in measured.items():
            where = f"{path}.measurements.{q}"
            if _is_signal(q, m):
                signals[name][q] = _signal(q, m, where)
            else:
                measurements[name][q] = _measurement(m, where)
        if "feed_override_percent" in op:
            where = f"{path}.feed_override_percent"
            given = op["feed_override_percent"]
            overrides[name] = _number(given, where, smallest=SMALLEST_MEASURED)
        if "edge_parts" in op:
            edges[name] = _edge_parts(op["edge_parts"], f"{path}.edge_parts")
        if "tool_wear" in op:
            wear[name] = _tool_wear(op["tool_wear"], f"{path}.tool_wear")
        if not (measured or name in wear or name in overrides):
            why = "nothing measured: give a measurement, tool_wear or feed_override_percent"
            raise InputError(f"{path}.measurements", measured, why)
    signals = {name: raw for name, raw in signals.items() if raw}
    serial = _identifier(table, "serial", "")
    return PartReport(serial, version, measurements, wear, signals, overrides, edges)


def _setpoint_version(version: object) -> int:
    """The setpoint version a part was made with: a whole number in ``1..LARGEST_WHOLE``."""
    if isinstance(version, bool) or not isinstance(version, int):
        raise InputError("setpoint_version", version, "must be a whole number >= 1")
    if not 1 <= version <= LARGEST_WHOLE:
        raise InputError("setpoint_version", version, f"must be in 1..{LARGEST_WHOLE}")
    return version


def _operation_list(operations: object) -> list[object]:
    """The report's operations: a list of 1 to :data:`MAX_OPERATIONS`."""
    if not isinstance(operations, list):
        raise InputError("operations", operations, "must be a list of operations")
    if not 1 <= len(operations) <= MAX_OPERATIONS:
        why = f"must list 1 to {MAX_OPERATIONS} operations (what was measured on the part)"
        raise InputError("operations", operations, why)
    return operations


def _edge_parts(n: object, where: str) -> int:
    """Parts the edge made before this one: a whole number in ``0..MAX_EDGE_PARTS``."""
    if isinstance(n, bool) or not isinstance(n, int) or not 0 <= n <= MAX_EDGE_PARTS:
        raise InputError(where, n, f"must be a whole number in 0..{MAX_EDGE_PARTS}")
    return n


def _tool_wear(data: object, where: str) -> ToolWear:
    """Flank wear measured after a volume: ``{"flank_wear_mm": reading, "volume_mm3"}``."""
    w = fields.mapping(data, where)
    fields.only_keys(w, ("flank_wear_mm", "volume_mm3"), where)
    if "volume_mm3" not in w:
        raise InputError(f"{where}.volume_mm3", None, "required field missing")
    return ToolWear(
        _measurement(w.get("flank_wear_mm"), f"{where}.flank_wear_mm"),
        _number(w["volume_mm3"], f"{where}.volume_mm3", smallest=SMALLEST_MEASURED),
    )


def _identifier(data: Mapping[str, object], key: str, path: str) -> str:
    """A serial or an operation name, normalised (:func:`models.fields.identity`)."""
    return fields.identity_field(data, key, path)


def _number(value: object, path: str, *, smallest: float = 0.0) -> float:
    """A finite number in ``[smallest, models.bounds.LARGEST]`` (not a bool, not a string)."""
    return fields.number(value, path, minimum=smallest)


def _is_signal(quantity: str, data: object) -> bool:
    """A spindle load always; a spindle current when it carries context or a calibration.

    ``spindle_current_A`` is also a model quantity (Tai et al. Eq. 14): given as a bare
    ``{value, uncertainty}`` it may be a measurement of that model; :mod:`supervisor.inputs.signals`
    decides by the operation's tool.
    """
    if quantity == "spindle_load_V":
        return True
    if quantity != "spindle_current_A" or not isinstance(data, Mapping):
        return False
    return any(k not in ("value", "uncertainty") for k in data)


def _signal(quantity: str, data: object, path: str) -> Signal:
    table = fields.mapping(data, path)
    fields.only_keys(table, ("value", "uncertainty", "calibration", *SIGNAL_CONTEXT), path)
    reading = _measurement({k: table[k] for k in ("value", "uncertainty") if k in table}, path)
    context = {k: _number(table[k], f"{path}.{k}") for k in SIGNAL_CONTEXT if k in table}
    calibration = _identifier(table, "calibration", path) if "calibration" in table else None
    return Signal(quantity, reading, context, calibration)


def _measurement(data: object, path: str) -> Measurement:
    """What a machine can measure: ``SMALLEST_MEASURED <= value <= LARGEST``, ``u < value``.

    Every reported quantity is a maximum (force, roughness, current, spindle load) or flank
    wear: a reading of 0 or one without uncertainty is no measurement.
    """
    table = fields.mapping(data, path)
    fields.only_keys(table, ("value", "uncertainty"), path)
    for key in ("value", "uncertainty"):
        if key not in table:
            raise InputError(f"{path}.{key}", None, "required field missing")
    value = _number(table["value"], f"{path}.value", smallest=SMALLEST_MEASURED)
    uncertainty = _number(table["uncertainty"], f"{path}.uncertainty", smallest=SMALLEST_MEASURED)
    if uncertainty >= value:
        where = f"{path}.uncertainty"
        raise InputError(where, table["uncertainty"], f"must be less than the value {value:g}")
    return Measurement(value, uncertainty)
