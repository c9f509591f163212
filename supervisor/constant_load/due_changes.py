"""The tool changes a part report's feed overrides call for, at the setpoints it was made with."""

from __future__ import annotations

from models.errors import InputError
from supervisor.constant_load.setpoint import ToolChange, tool_change
from supervisor.inputs.part_report import PartReport
from supervisor.optimize.result import PlanResult


def tool_changes(report: PartReport, made_with: PlanResult) -> tuple[ToolChange, ...]:
    """One :class:`ToolChange` per reported feed override, in the report's order.

    Raises
    ------
    InputError
        An override for an operation the plan does not have, or one without constant-load
        control; the field is named.
    """
    setpoints = {op.name: op for op in made_with.operations}
    changes = []
    for name, percent in report.feed_overrides.items():
        where = f"operations.{name}.feed_override_percent"
        if name not in setpoints:
            raise InputError(where, percent, f"{name!r} is not an operation of the plan")
        constant_load = setpoints[name].constant_load
        if constant_load is None:
            raise InputError(where, percent, f"operation {name!r} has no constant-load control")
        changes.append(tool_change(name, constant_load, percent))
    return tuple(changes)
