"""The paper's demonstration end to end: catalogue (C), robust start (R), then RCB part by part.

Ivester & Heigel Table 5 compares the vendor's catalogue parameters (rows C), the robust
optimum (rows R) and the parameters adaptive control reached (rows AC). Here the parts are
made on a :mod:`virtual machine <supervisor.simulate>` whose true process lies inside the
bands, and each part's measurements go through :func:`supervisor.rcb.update`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from models import kinematics
from models.powerlaw import Prediction
from models.tool import predict_all
from supervisor.plan import Plan
from supervisor.rcb import Decision, RcbSettings, RcbState, start, update
from supervisor.report import Measurement, PartReport
from supervisor.simulate import VirtualMachine, run_part, sample_machine


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
    decisions: tuple[tuple[Decision, ...], ...]


def run_demo(
    plan: Plan,
    parts: int,
    seed: int,
    settings: RcbSettings | None = None,
    on_part: Callable[[int], None] | None = None,
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
    """
    machine = sample_machine(plan, seed)
    rng = np.random.default_rng(seed)
    state = start(plan, settings)
    catalog = _catalog_rows(plan, machine, rng)
    robust_setpoints = state.setpoints
    first: Mapping[str, Mapping[str, Measurement]] = {}
    violations = 0
    trail: list[tuple[Decision, ...]] = []
    for i in range(parts):
        setpoints = {op.name: op.setpoint for op in state.setpoints.operations}
        outcome = run_part(machine, setpoints, rng)
        violations += len(outcome.violations)
        if i == 0:
            first = outcome.measurements
        report = PartReport(f"{seed}-{i + 1}", state.version, outcome.measurements)
        state, decisions = update(state, report)
        trail.append(decisions)
        if on_part is not None:
            on_part(i + 1)
    # one more part at the final setpoints shows what they make (measured, not applied)
    check = run_part(machine, {op.name: op.setpoint for op in state.setpoints.operations}, rng)
    violations += len(check.violations)
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
                    check.measurements.get(final.name, {}),
                ),
            )
        )
    has_catalog = len(catalog) == len(plan.operations)
    cycle = {
        "catalog": sum(r.time_min for r in catalog.values()) if has_catalog else None,
        "robust": robust_setpoints.cycle_time_min,
        "final": state.setpoints.cycle_time_min,
    }
    return DemoResult(
        operations=tuple(rows),
        cycle_time_min=cycle,
        violations=violations,
        parts=parts,
        flagged=sum(d.flagged for ds in trail for d in ds),
        final_state=state,
        decisions=tuple(trail),
    )


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
