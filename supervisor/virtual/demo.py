"""The paper's demonstration end to end: catalogue (C), robust start (R), then RCB part by part.

Ivester & Heigel Table 5 compares the vendor's catalogue parameters (rows C), the robust
optimum (rows R) and the parameters adaptive control reached (rows AC). Here the parts are
made on a :mod:`virtual machine <supervisor.virtual.simulate>` whose true process lies inside the
bands, and each part's measurements go through :func:`supervisor.rcb.update.update`.

Where the plan's machine has a calibration that turns a spindle reading into force (Kim &
Jeon's spindle current, Ivester & Heigel's spindle load), the force of every operation that
limits it is reported as that reading, made by a :mod:`virtual sensor <supervisor.virtual.sensing>`
from the true force, and converted back by :func:`supervisor.inputs.signals.resolve` exactly as a
part report from the MES would be: the band then shrinks against the conversion's
uncertainty, not the dynamometer's.

Each report is applied by an :data:`Apply`: in memory by default, or stored as the MES's
would be (``rcb demo`` stores its plan and parts in an embedded database: api.services.demo).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from models import kinematics
from models.powerlaw import Prediction
from models.quantities import PARTS_PER_EDGE
from models.sensors import Calibration
from models.sensors.convert import converts
from models.tool import predict_all
from supervisor.inputs.part_report import Measurement, PartReport, Signal
from supervisor.inputs.plan import Plan
from supervisor.inputs.signals import operating_point, resolve
from supervisor.optimize.optimizer import optimize_plan
from supervisor.optimize.result import PlanResult
from supervisor.rcb.state import RcbSettings, RcbState
from supervisor.rcb.update import start, update
from supervisor.virtual.machine import DEFAULT_UNCERTAINTY, PartOutcome, VirtualMachine
from supervisor.virtual.sampling import oracle_tools, sample_machine
from supervisor.virtual.sensing import noisy_reading
from supervisor.virtual.simulate import run_part

#: Expanded uncertainty of the milling demonstration's spindle current readings [A]: 0.5 % of
#: the 4 A Kim & Jeon's spindle draws near its force limit (§6.2.3), the relative accuracy
#: :data:`supervisor.virtual.machine.DEFAULT_UNCERTAINTY` assumes for a current transducer.
MILLING_DEMO_UNCERTAINTY: Mapping[str, float] = {"spindle_current_A": 0.02}


#: Applies a part's report, as the MES sends it (spindle readings as read), to the state it was
#: made with: the next state and the number of measurements flagged (:func:`in_memory`, or
#: the database's: api.services.demo).
Apply = Callable[[RcbState, PartReport], tuple[RcbState, int]]


def in_memory(state: RcbState, report: PartReport) -> tuple[RcbState, int]:
    """:func:`supervisor.rcb.update.update`, nothing stored.

    The report as the MES sends it: its spindle readings are resolved to force at the
    setpoints the part was made with first, as the service does.
    """
    resolved, _ = resolve(report, state.plan, state.setpoints)
    new_state, decisions = update(state, resolved)
    return new_state, sum(d.flagged for d in decisions)


@dataclass(frozen=True)
class Row:
    """One row of a Table-5-like table: parameters, rate, predictions, measurements."""

    setpoint: Mapping[str, float]
    mrr_cm3_min: float
    time_min: float
    predicted: Mapping[str, Prediction]
    measured: Mapping[str, Measurement]


@dataclass(frozen=True)
class OperationRows:
    """Catalogue, robust start and final rows of one operation."""

    name: str
    catalog: Row | None
    robust: Row
    final: Row


@dataclass(frozen=True)
class DemoResult:
    """The whole demonstration."""

    operations: tuple[OperationRows, ...]
    cycle_time_min: Mapping[str, float | None]
    violations: int
    parts: int
    flagged: int
    final_state: RcbState


def run_demo(
    plan: Plan,
    parts: int,
    seed: int,
    settings: RcbSettings | None = None,
    on_part: Callable[[int], None] | None = None,
    uncertainty: Mapping[str, float] | None = None,
    apply: Apply = in_memory,
) -> DemoResult:
    """Make ``parts`` parts with RCB on a virtual machine drawn with ``seed``.

    Parameters
    ----------
    plan : Plan
        The plan; operations with a ``catalog_setpoint`` get a catalogue row.
    parts : int
        Parts made with RCB (each one reported and applied); one more part at the final
        setpoints gives the final row's measurements and counts for violations too.
    seed : int
        Seed of the true process and of the measurement noise.
    settings : RcbSettings, optional
        The RCB law (strategy, alpha, floors).
    on_part : callable, optional
        Called with the number of parts made so far, for progress display.
    uncertainty : Mapping[str, float], optional
        Expanded measurement uncertainty per quantity, over
        :data:`supervisor.virtual.machine.DEFAULT_UNCERTAINTY` (``spindle_current_A`` and
        ``spindle_load_V`` for the virtual spindle sensor).
    apply : Apply, optional
        What applies each part's report (:func:`in_memory`: nothing stored).
    """
    machine = sample_machine(plan, seed, uncertainty=uncertainty)
    rng = np.random.default_rng(seed)
    initial = start(plan, settings)
    catalog = _catalog_rows(plan, machine, rng)
    made = _make_parts(plan, machine, initial, parts, (seed, rng), on_part, apply)
    state, first, violations, flagged = made
    # one more part at the final setpoints shows what they make (measured, not applied)
    check = run_part(machine, {op.name: op.setpoint for op in state.setpoints.operations}, rng)
    violations += len(check.violations)
    rows = _operation_rows(plan, machine, catalog, initial.setpoints, state, first, check, rng)
    return DemoResult(
        operations=rows,
        cycle_time_min=_cycles(plan, machine, catalog, initial.setpoints, state.setpoints),
        violations=violations,
        parts=parts,
        flagged=flagged,
        final_state=state,
    )


def _make_parts(
    plan: Plan,
    machine: VirtualMachine,
    state: RcbState,
    parts: int,
    seeded: tuple[int, np.random.Generator],
    on_part: Callable[[int], None] | None,
    apply: Apply,
) -> tuple[RcbState, Mapping[str, Mapping[str, Measurement]], int, int]:
    """``parts`` parts, each reported and applied.

    Returns the state, part 1's readings, the violations and the measurements flagged.
    """
    seed, rng = seeded
    edge_life = {
        op.name: max(1, math.floor(op.limits[PARTS_PER_EDGE]))
        for op in plan.operations
        if PARTS_PER_EDGE in op.limits
    }
    first: Mapping[str, Mapping[str, Measurement]] = {}
    violations = flagged = 0
    for i in range(parts):
        setpoints = {op.name: op.setpoint for op in state.setpoints.operations}
        outcome = run_part(machine, setpoints, rng)
        violations += len(outcome.violations)
        ages = {name: i % n for name, n in edge_life.items()}  # edges changed after n parts
        report = _report(
            plan, machine, state.setpoints, outcome, f"{seed}-{i + 1}", state.version, rng, ages
        )
        if i == 0:
            first = resolve(report, plan, state.setpoints)[0].measurements
        state, count = apply(state, report)
        flagged += count
        if on_part is not None:
            on_part(i + 1)
    return state, first, violations, flagged


def _operation_rows(
    plan: Plan,
    machine: VirtualMachine,
    catalog: Mapping[str, Row],
    robust_setpoints: PlanResult,
    state: RcbState,
    first: Mapping[str, Mapping[str, Measurement]],
    check: PartOutcome,
    rng: np.random.Generator,
) -> tuple[OperationRows, ...]:
    """Per operation its catalogue, robust (with part 1's readings) and final rows."""
    rows = []
    for robust, final in zip(robust_setpoints.operations, state.setpoints.operations, strict=True):
        rows.append(
            OperationRows(
                name=robust.name,
                catalog=catalog.get(robust.name),
                robust=Row(
                    robust.setpoint,
                    robust.mrr_cm3_min,
                    robust.time_min,
                    robust.predicted,
                    first.get(robust.name, {}),
                ),
                final=Row(
                    final.setpoint,
                    final.mrr_cm3_min,
                    final.time_min,
                    final.predicted,
                    _sensed(plan, machine, state.setpoints, check, rng).get(final.name, {}),
                ),
            )
        )
    return tuple(rows)


def _cycles(
    plan: Plan,
    machine: VirtualMachine,
    catalog: Mapping[str, Row],
    robust: PlanResult,
    final: PlanResult,
) -> dict[str, float | None]:
    """Cycle times of the catalogue (None unless every operation has one), robust, final, oracle."""
    has_catalog = len(catalog) == len(plan.operations)
    # the oracle: the same plan optimised with the true models and no band, the fastest any
    # controller could run on this machine without crossing a true limit
    oracle = optimize_plan(plan, tools=oracle_tools(machine))
    return {
        "catalog": sum(r.time_min for r in catalog.values()) if has_catalog else None,
        "robust": robust.cycle_time_min,
        "final": final.cycle_time_min,
        "oracle": oracle.cycle_time_min,
    }


def _catalog_rows(plan: Plan, machine: VirtualMachine, rng: np.random.Generator) -> dict[str, Row]:
    """Rows C: the catalogue parameters, predicted with the catalogue models, one part made."""
    setpoints = {op.name: op.catalog_setpoint for op in plan.operations if op.catalog_setpoint}
    if not setpoints:
        return {}
    outcome = run_part(machine, setpoints, rng)
    rows = {}
    for op in plan.operations:
        if op.name not in setpoints:
            continue
        point = {**op.catalog_setpoint, **op.context}
        mrr = kinematics.mrr_monomial(op.process).evaluate(point)
        rows[op.name] = Row(
            setpoint=op.catalog_setpoint,
            mrr_cm3_min=mrr,
            time_min=kinematics.machining_time_min(op.volume_mm3, mrr),
            predicted=predict_all(plan.tools[op.tool], point, op.setpoint_rel_uncertainty),
            measured=outcome.measurements.get(op.name, {}),
        )
    return rows


def _force_sensor(plan: Plan) -> tuple[str, Calibration] | None:
    """The machine's one calibration that turns a spindle reading into force, if any."""
    found = [(n, c) for n, c in plan.machine.calibrations.items() if converts(c) is not None]
    return found[0] if len(found) == 1 else None


def _report(
    plan: Plan,
    machine: VirtualMachine,
    made_with: PlanResult,
    outcome: PartOutcome,
    serial: str,
    version: int,
    rng: np.random.Generator,
    edge_parts: Mapping[str, int] | None = None,
) -> PartReport:
    """The part report the MES sends: forces as spindle readings where the machine has a sensor.

    ``edge_parts``: each counted edge's age, as the control's tool-life counter gives it.
    :func:`supervisor.inputs.signals.resolve` converts its readings to ``force_N`` with the
    conversion's uncertainty, as the service does.
    """
    sensor = _force_sensor(plan)
    ages = dict(edge_parts or {})
    if sensor is None:
        return PartReport(serial, version, outcome.measurements, edge_parts=ages)
    name, calibration = sensor
    raw = converts(calibration)
    assert raw is not None  # _force_sensor keeps only force calibrations
    u = machine.uncertainty.get(raw, DEFAULT_UNCERTAINTY.get(raw, 0.0))
    measurements = {op: dict(m) for op, m in outcome.measurements.items()}
    signals: dict[str, dict[str, Signal]] = {}
    setpoints = {op.name: op.setpoint for op in made_with.operations}
    for op in plan.operations:
        if "force_N" not in op.limits or "force_N" not in measurements.get(op.name, {}):
            continue
        del measurements[op.name]["force_N"]
        point = operating_point(op.process, {**op.context, **setpoints[op.name]})
        force = outcome.true_values[op.name]["force_N"]
        reading = noisy_reading(calibration, force, point, u, rng)
        signals[op.name] = {raw: Signal(raw, Measurement(reading, u), calibration=name)}
    return PartReport(serial, version, measurements, signals=signals, edge_parts=ages)


def _sensed(
    plan: Plan,
    machine: VirtualMachine,
    made_with: PlanResult,
    outcome: PartOutcome,
    rng: np.random.Generator,
) -> Mapping[str, Mapping[str, Measurement]]:
    """The measurements of a part as the supervisor sees them (see :func:`_report`)."""
    report = _report(plan, machine, made_with, outcome, "", 0, rng)
    return resolve(report, plan, made_with)[0].measurements
