"""One closed-loop scenario of a certificate: a virtual machine, RCB, ``parts`` parts.

What a scenario does, row by row, is described in :mod:`supervisor.virtual.certify`, which runs
many of them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from models.quantities import PARTS_PER_EDGE
from supervisor.inputs.part_report import PartReport
from supervisor.inputs.plan import Plan
from supervisor.optimize.result import PlanResult
from supervisor.rcb.state import Halt, RcbState
from supervisor.rcb.update import update
from supervisor.virtual.certificate import FloatArray, ScenarioTrace
from supervisor.virtual.fault_log import FaultLog
from supervisor.virtual.fault_oracle import truth_oracle
from supervisor.virtual.fault_spec import Faults, with_wear
from supervisor.virtual.faults import PartFaults, step_factor, unavoidable_parts
from supervisor.virtual.machine import PartOutcome, VirtualMachine
from supervisor.virtual.sampling import sample_machine
from supervisor.virtual.simulate import run_part


def _record(result: PlanResult, oracle: PlanResult) -> tuple[float, FloatArray, float]:
    """Plan MRR/oracle ratio, per-operation MRR/oracle ratios, cycle time."""
    pairs = zip(result.operations, oracle.operations, strict=True)
    ops = np.array([r.mrr_cm3_min / o.mrr_cm3_min for r, o in pairs])
    cycle = result.cycle_time_min
    return oracle.cycle_time_min / cycle, ops, cycle


def _edge_life_parts(plan: Plan) -> dict[str, int | None]:
    """Parts an edge makes before it is changed, per operation (None: never in a run).

    The edges of operations with a ``parts_per_edge`` limit are changed after that many parts,
    and the MES reports each one's age (``edge_parts``), as a control's tool-life counter does.
    """
    out: dict[str, int | None] = {}
    for op in plan.operations:
        limit = op.limits.get(PARTS_PER_EDGE)
        out[op.name] = None if limit is None else max(1, math.floor(limit))
    return out


def _halted_operation(halt: Halt) -> str:
    """The operations a halt names, comma-separated."""
    return ",".join(o.operation for o in halt.operations)


def run_scenario(
    initial: RcbState,
    seed: int,
    parts: int,
    *,
    wear_drift_per_edge_life: float = 0.0,
    faults: Faults | None = None,
) -> ScenarioTrace:
    """Make ``parts`` parts with RCB from ``initial`` on the virtual machine of ``seed``.

    Parameters
    ----------
    initial : RcbState
        The robust start, ``start(plan, RcbSettings(strategy=...))``; its plan is the plan.
    seed : int
        Seed of the true process and of the measurement noise (``>= 0``); every fault's
        stream is derived from it (:func:`supervisor.virtual.faults.fault_rng`).
    parts : int
        Parts to make, ``K >= 1``.
    wear_drift_per_edge_life : float
        Relative rise of force, roughness and spindle current over an edge's life [-]
        (module docstring for the edge changes); the alias of the fault ``wear:D``.
    faults : Faults, optional
        The faults of the shop floor (:mod:`supervisor.virtual.fault_spec`); none by default,
        and then every result is as before the fault catalogue.

    Returns
    -------
    ScenarioTrace
        MRR/oracle and cycle time after ``k = 0..parts`` parts (row ``k`` against the oracle
        of the truth part ``k + 1`` is made with), violations per part, the unavoidable
        parts, what each fault did and where the scenario stopped.
    """
    faults = with_wear(faults or Faults(), wear_drift_per_edge_life)
    machine = sample_machine(initial.plan, seed=seed, wear_drift_per_edge_life=faults.wear)
    return run_machine(initial, machine, seed, parts, faults=faults)[0]


def _worn(machine: VirtualMachine, faults: Faults) -> VirtualMachine:
    """``machine`` whose edges wear by ``faults``' rise, if it has one.

    A machine drawn without wear (a fleet's, :mod:`supervisor.virtual.fleet`); one drawn with
    it (:func:`run_scenario`'s) is returned as it is, not compiled again.
    """
    if faults.wear in (0.0, machine.wear_drift_per_edge_life):
        return machine
    return replace(machine, wear_drift_per_edge_life=faults.wear)


def run_machine(
    initial: RcbState,
    machine: VirtualMachine,
    seed: int,
    parts: int,
    *,
    faults: Faults | None = None,
    noise_seed: int | Sequence[int] | None = None,
    on_report: Callable[[RcbState, RcbState], None] = lambda before, after: None,
) -> tuple[ScenarioTrace, RcbState]:
    """:func:`run_scenario` on a given ``machine``; also the state after the last report.

    ``noise_seed``: the seed of the measurement noise (``seed`` when not given): the machines
    of a fleet (:mod:`supervisor.virtual.fleet`) each draw their own. ``faults`` wear it too.
    ``on_report(before, after)``: called with the states around each report.
    """
    plan, faults = initial.plan, faults or Faults()
    machine = _worn(machine, faults)
    log = FaultLog(faults, machine, seed) if faults else None
    oracles = _Oracles(machine, faults, log)
    edge_life = _edge_life_parts(plan)
    state = initial
    rng = np.random.default_rng(seed if noise_seed is None else noise_seed)
    plan_ratio, cycle = np.zeros(parts + 1), np.full(parts + 1, np.nan)
    op_ratio = np.zeros((parts + 1, len(plan.operations)))
    violations = np.zeros(parts, dtype=np.int64)
    where: list[tuple[int, str, str]] = []
    stopped_at, stopped_op, made = 0, "", 0
    for k in range(1, parts + 1):
        plan_ratio[k - 1], op_ratio[k - 1], cycle[k - 1] = _record(
            state.setpoints, oracles.row(k - 1)
        )
        outcome, report = _make_part(machine, state, k, seed, rng, edge_life, log)
        made, violations[k - 1] = k, len(outcome.violations)
        where += [(k, v.operation, v.quantity) for v in outcome.violations]
        before, (state, _) = state, update(state, report)
        on_report(before, state)
        if state.halt is not None:
            stopped_at, stopped_op = k, _halted_operation(state.halt)
            break
    if not stopped_at:
        plan_ratio[parts], op_ratio[parts], cycle[parts] = _record(
            state.setpoints, oracles.row(parts)
        )
    trace = ScenarioTrace(
        seed=seed,
        oracle_cycle_min=oracles.first.cycle_time_min,
        plan_ratio=plan_ratio,
        op_ratio=op_ratio,
        cycle_min=cycle,
        violations=violations,
        where=tuple(where),
        stopped_at=stopped_at,
        stopped_op=stopped_op,
        parts_made=made,
        unavoidable_at=unavoidable_parts(faults, parts),
        tallies=log.tallies() if log else (),
        oracle_changes=tuple(oracles.changes),
    )
    return trace, state


class _Oracles:
    """The oracle of each truth a part is made with (a step changes it), solved once each."""

    def __init__(self, machine: VirtualMachine, faults: Faults, log: FaultLog | None) -> None:
        self._machine, self._faults, self._log = machine, faults, log
        self._solved: dict[float, PlanResult] = {}
        self.first = self._of(1)
        self._current = self.first
        #: ``(row, oracle cycle time)`` of every row whose oracle is not the row before's.
        self.changes: list[tuple[int, float]] = []

    def _of(self, part: int) -> PlanResult:
        """The oracle of the truth part ``part`` is made with."""
        factor = step_factor(self._faults, part)
        if factor not in self._solved:
            log = self._log
            truth = (
                PartFaults(factor, bends=log.bends) if log and self._faults.beyond_wear else None
            )
            self._solved[factor] = truth_oracle(self._machine, truth)
        return self._solved[factor]

    def row(self, row: int) -> PlanResult:
        """The oracle of row ``row`` (the truth part ``row + 1`` is made with)."""
        oracle = self._of(row + 1)
        if oracle is not self._current:
            self.changes.append((row, oracle.cycle_time_min))
            self._current = oracle
        return oracle


def _make_part(
    machine: VirtualMachine,
    state: RcbState,
    k: int,
    seed: int,
    rng: np.random.Generator,
    edge_life: dict[str, int | None],
    log: FaultLog | None,
) -> tuple[PartOutcome, PartReport]:
    """Part ``k`` at the setpoints in force, and its report with the counted edges' ages."""
    setpoints = {op.name: op.setpoint for op in state.setpoints.operations}
    edge_parts = {name: (k - 1) if n is None else (k - 1) % n for name, n in edge_life.items()}
    outcome = run_part(machine, setpoints, rng, edge_parts, faults=log.for_part(k) if log else None)
    if log:
        log.record(k, setpoints, outcome, edge_parts)
    ages = {name: edge_parts[name] for name, n in edge_life.items() if n is not None}
    report = PartReport(f"{seed}-{k}", state.version, outcome.measurements, edge_parts=ages)
    return outcome, report
