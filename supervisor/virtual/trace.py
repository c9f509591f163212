"""A spindle-load trace of a virtual lathe making parts: what a machine publishes, sample by sample.

For every operation of a plan the virtual machine (:mod:`supervisor.virtual.simulate`) gives the
true cutting force at the setpoint; the machine's calibration run backwards
(:func:`supervisor.virtual.sensing.reading_for_force`) gives the spindle load (or current) that
force shows. The program of each operation is five blocks ``N{100·k}`` .. ``N{100·k + 40}``
(k = 1, 2 ... in plan order): a tool change ``T{k}``, an approach and a retract at the idle load,
and two cutting blocks at 97 % and 100 % of the force. Each block lasts ``samples_per_block``
samples, each with Gaussian noise of standard deviation ``noise`` (the instrument's). After the
last operation the program ends (block ``N9000``), the part count rises by one and the machine
waits ``READY`` for two samples. The samples are what the test machines (an OPC UA server, an
MTConnect agent) play and what a demo can show; the map ``OP=N100:N140`` of each operation is
:func:`block_map`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from models import kinematics
from models.sensors import Calibration
from supervisor.inputs.plan import Plan
from supervisor.virtual.machine import VirtualMachine
from supervisor.virtual.sensing import reading_for_force
from supervisor.virtual.simulate import run_part

#: Load factor of each block of an operation: tool change, approach, two cuts, retract.
BLOCK_LOAD = (0.0, 0.0, 0.97, 1.0, 0.0)
#: The block that ends the program (M30), outside every operation.
END_BLOCK = 9000
#: Samples the machine waits READY between parts.
READY_SAMPLES = 2


@dataclass(frozen=True)
class TraceSample:
    """What the machine publishes at one instant (one sample of every signal)."""

    part_count: int
    execution: str
    block: int
    tool_number: int
    spindle_load: float
    spindle_speed_rpm: float
    feed_rate_mm_min: float


@dataclass(frozen=True)
class TracedOperation:
    """One operation as the program runs it: its blocks, tool, speed, feed rate and loads."""

    name: str
    first_block: int
    tool_number: int
    spindle_speed_rpm: float
    feed_rate_mm_min: float
    idle_load: float
    cutting_load: float

    @property
    def blocks(self) -> tuple[int, ...]:
        """The block numbers, ``N first`` in steps of 10."""
        return tuple(self.first_block + 10 * i for i in range(len(BLOCK_LOAD)))


def traced_operations(
    plan: Plan,
    setpoints: Mapping[str, Mapping[str, float]],
    machine: VirtualMachine,
    calibration: Calibration,
    seed: int,
) -> tuple[TracedOperation, ...]:
    """The turning operations of ``plan`` with a force limit, at ``setpoints``, on ``machine``.

    The cutting load is the reading the calibration gives for the true force at the setpoint;
    the idle load the reading for zero force (the calibration's idle load at that speed).
    """
    outcome = run_part(machine, setpoints, np.random.default_rng(seed))
    traced = []
    for k, op in enumerate(plan.operations, start=1):
        if op.process != "turning" or "force_N" not in op.limits:
            continue
        point = {**op.context, **setpoints[op.name]}
        rpm = kinematics.turning_spindle_rpm(point["speed_m_min"], point["workpiece_diameter_mm"])
        feed_rate = rpm * point["feed_mm_rev"]
        context = {**point, "spindle_speed_rpm": rpm, "feed_rate_mm_min": feed_rate}
        force = outcome.true_values[op.name]["force_N"]
        traced.append(
            TracedOperation(
                name=op.name,
                first_block=100 * k,
                tool_number=k,
                spindle_speed_rpm=rpm,
                feed_rate_mm_min=feed_rate,
                idle_load=reading_for_force(calibration, 0.0, context),
                cutting_load=reading_for_force(calibration, force, context),
            )
        )
    return tuple(traced)


def block_map(operations: Sequence[TracedOperation]) -> list[str]:
    """``["rough-od=N100:N140", ...]``: the ``rcb gcode --map`` / collector map of the program."""
    return [f"{op.name}=N{op.blocks[0]}:N{op.blocks[-1]}" for op in operations]


def part_trace(
    operations: Sequence[TracedOperation],
    part_count_before: int,
    rng: np.random.Generator,
    *,
    samples_per_block: int = 3,
    noise: float = 0.004,
) -> list[TraceSample]:
    """The samples of one part: every block of every operation, then the count and READY."""
    samples = []
    for op in operations:
        for block, factor in zip(op.blocks, BLOCK_LOAD, strict=True):
            level = op.idle_load + factor * (op.cutting_load - op.idle_load)
            for _ in range(samples_per_block):
                load = max(level + noise * float(rng.standard_normal()), 0.0)
                samples.append(
                    TraceSample(
                        part_count_before,
                        "ACTIVE",
                        block,
                        op.tool_number,
                        load,
                        op.spindle_speed_rpm,
                        op.feed_rate_mm_min,
                    )
                )
    last = operations[-1]
    for _ in range(READY_SAMPLES):
        samples.append(
            TraceSample(part_count_before + 1, "READY", END_BLOCK, last.tool_number, 0.0, 0.0, 0.0)
        )
    return samples


def machine_trace(
    operations: Sequence[TracedOperation],
    parts: int,
    seed: int,
    *,
    samples_per_block: int = 3,
    noise: float = 0.004,
) -> list[TraceSample]:
    """``parts`` parts one after another, from part count 0, starting READY."""
    rng = np.random.default_rng(seed)
    first = operations[0]
    trace = [TraceSample(0, "READY", END_BLOCK, first.tool_number, 0.0, 0.0, 0.0)]
    for count in range(parts):
        trace += part_trace(
            operations, count, rng, samples_per_block=samples_per_block, noise=noise
        )
    return trace
