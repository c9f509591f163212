"""The virtual lathe ``rcb virtual serve`` publishes: a plan file's parts as a spindle-load trace.

The plan is optimised as the REST service optimises a new plan (its setpoint version 1,
:func:`supervisor.optimize.optimizer.optimize_plan`); a virtual machine's true processes are
drawn inside the plan's model bands (:func:`supervisor.virtual.sampling.sample_machine`, seeded);
every turning operation with a force limit is run at its version-1 setpoint and shown through
the plan's spindle-load calibration (:mod:`supervisor.virtual.trace`). Every part is made at
the same setpoints, as by a machine whose program is not rewritten: the service learns from
each part and publishes new setpoint versions, which the machine does not take
(docs/try-a-machine.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from api.virtual_serve import MAX_PARTS
from models.errors import InputError
from supervisor.inputs.plan import Plan, load_plan
from supervisor.optimize.optimizer import optimize_plan
from supervisor.virtual.sampling import sample_machine
from supervisor.virtual.trace import (
    TracedOperation,
    TraceSample,
    block_map,
    machine_trace,
    traced_operations,
)

#: The calibration the trace is shown through: ``[machine.calibrations.spindle_load]``.
CALIBRATION = "spindle_load"
#: The setpoint version every part is made with (the service's first).
SETPOINT_VERSION = 1


@dataclass(frozen=True)
class VirtualLathe:
    """A plan's parts on the virtual lathe: operations, trace and where each part ends."""

    plan: Plan
    operations: tuple[TracedOperation, ...]
    trace: list[TraceSample]
    #: Samples written once part ``k`` (1-based, index ``k - 1``) is made.
    part_ends: tuple[int, ...]

    def operation_map(self) -> list[str]:
        """The collector's ``[signal] operations`` (``rough-od=N100:N140`` ...)."""
        return block_map(self.operations)

    def peaks(self, part: int) -> dict[str, float]:
        """The peak spindle load of every operation of part ``part`` (1-based) [V]."""
        begin = 0 if part == 1 else self.part_ends[part - 2]
        samples = self.trace[begin : self.part_ends[part - 1]]
        return {
            op.name: max(
                (
                    s.spindle_load
                    for s in samples
                    if s.execution == "ACTIVE" and s.block in op.blocks
                ),
                default=0.0,
            )
            for op in self.operations
        }


def build(plan_path: Path, parts: int, seed: int) -> VirtualLathe:
    """The virtual lathe making ``parts`` parts of the plan in ``plan_path``.

    Errors name ``--plan`` (no spindle-load calibration, no operation to trace) or ``--parts``.
    """
    if not 1 <= parts <= MAX_PARTS:
        raise InputError("--parts", parts, f"must be a whole number in 1..{MAX_PARTS}")
    plan = load_plan(plan_path)
    calibration = plan.machine.calibrations.get(CALIBRATION)
    if calibration is None:
        raise InputError(
            "--plan",
            str(plan_path),
            f"has no [machine.calibrations.{CALIBRATION}] table: the virtual lathe publishes "
            "its spindle load through it (rcb examples copy virtual_lathe_part has one)",
        )
    result = optimize_plan(plan)
    setpoints = {op.name: op.setpoint for op in result.operations}
    machine = sample_machine(plan, seed)
    operations = traced_operations(plan, setpoints, machine, calibration, seed)
    if not operations:
        raise InputError("--plan", str(plan_path), "has no turning operation with a force limit")
    trace = machine_trace(operations, parts, seed)
    return VirtualLathe(plan, operations, trace, _part_ends(trace))


def _part_ends(trace: list[TraceSample]) -> tuple[int, ...]:
    """Where each part's samples end: where the next part starts cutting, or the trace ends."""
    starts = [
        i
        for i in range(1, len(trace))
        if trace[i].execution == "ACTIVE" and trace[i - 1].execution != "ACTIVE"
    ]
    return (*starts[1:], len(trace))
