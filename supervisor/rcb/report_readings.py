"""The readings of a part report and the setpoints they were made at, checked whole.

:func:`supervisor.rcb.update.update` refuses a report before applying any of it: an unknown
operation, a quantity its tool has no model of (a misspelt one: the name meant, ``unknown
quantity 'Force_N'; did you mean force_N?``), a setpoint version the state does not hold.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from models.errors import InputError
from models.misspelt import meant
from models.quantities import QUANTITIES
from models.tool import Tool
from supervisor.inputs.part_report import Measurement, PartReport, counted
from supervisor.inputs.plan import Operation
from supervisor.optimize.passes import measured_at
from supervisor.optimize.result import OperationResult, PlanResult
from supervisor.rcb.law import tool_life_measured
from supervisor.rcb.state import RcbState


def report_readings(
    state: RcbState,
    report: PartReport,
    operations: Mapping[str, Operation],
    results: Mapping[str, OperationResult],
) -> list[tuple[str, str, Measurement]]:
    """Every reading of the report (tool wear as tool life), the whole report checked first.

    Each as it is counted: its uncertainty at least the least a chain can claim
    (:func:`~supervisor.inputs.part_report.counted`).
    """
    for name in [*report.measurements, *report.tool_wear]:
        if name not in operations:
            raise InputError(f"operations.{name}", name, f"not an operation of {state.plan.name!r}")
    measured_items = [
        (name, quantity, measurement)
        for name, measured in report.measurements.items()
        for quantity, measurement in measured.items()
    ]
    for name, quantity, measurement in measured_items:
        if quantity == "tool_life_mm3":  # what an edge's wear says, not a reading of a part
            raise InputError(
                f"operations.{name}.measurements.tool_life_mm3",
                measurement.value,
                "tool life is not measured: report the edge's flank wear and the volume it cut"
                " as tool_wear (flank_wear_mm, volume_mm3)",
            )
    for name, wear in report.tool_wear.items():
        check_quantity(state.tools[name], name, "tool_life_mm3", f"operations.{name}.tool_wear")
        wear_measured = tool_life_measured(
            state, *measured_at(operations[name], results[name], "tool_life_mm3"), wear
        )
        measured_items.append((name, "tool_life_mm3", wear_measured))
    for name, quantity, _ in measured_items:  # check the whole report before applying any
        check_quantity(state.tools[name], name, quantity)
    return [(name, quantity, counted(m)) for name, quantity, m in measured_items]


def setpoints_of(state: RcbState, report: PartReport, made_with: PlanResult | None) -> PlanResult:
    """The setpoints of the report's version: the current ones, or ``made_with`` (older)."""
    if report.setpoint_version == state.version:
        return state.setpoints
    if made_with is not None and 1 <= report.setpoint_version < state.version:
        return made_with
    raise InputError(
        "setpoint_version",
        report.setpoint_version,
        f"unknown here: the current version is {state.version}",
    )


def check_quantity(tool: Tool, operation: str, quantity: str, where: str | None = None) -> None:
    """Refuse a quantity ``tool`` has no model of, naming what it can measure.

    ``where``: the report's field (default: the operation's measurement of ``quantity``).
    """
    if quantity not in tool.models:
        measurable = [q for q in tool.models if q != "tool_life_mm3"]
        known = ", ".join(measurable) or "none"
        meant = meant_quantity(quantity, measurable)
        reason = f"tool {tool.name!r} has no model of it; measurable: {known}"
        if meant is not None:  # one line: the CLI's collector prints it as its error
            reason = f"unknown quantity {quantity!r}; did you mean {meant}? measurable: {known}"
        raise InputError(
            where or f"operations.{operation}.measurements.{quantity}", quantity, reason
        )


def meant_quantity(name: str, measurable: Sequence[str]) -> str | None:
    """The measurable quantity ``name`` misspells (case, white space, a letter), or None.

    None for a quantity of the registry (:data:`models.quantities.QUANTITIES`): a tool without
    its model is what the message says then, not a misspelling.
    """
    return None if name in QUANTITIES else meant(name, measurable)
