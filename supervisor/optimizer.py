"""The robust optimiser: one parametrised (DPP) cvxpy program per problem shape, solved by HiGHS.

A program is built once per (number of parameters, number of constraint rows) and re-solved
with new parameter values, so re-optimising after every part costs one solver call
(cvxpy "Disciplined Parametrized Programming").
"""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from typing import Any

import cvxpy as cp
import numpy as np

from models import kinematics
from models.errors import ModelDomainError
from models.kinematics import Process
from models.powerlaw import Prediction
from models.tool import Tool, predict_all
from supervisor.errors import Conflict, InfeasibleError, PlanError, SolverError
from supervisor.formulation import LogLinearProgram, formulate
from supervisor.plan import Machine, Operation, Plan

#: A row or bound whose slack in ln-space is below this is binding (1 ppm relative).
BINDING_TOL = 1e-6
#: A re-checked prediction may exceed its limit by at most this fraction (solver tolerance).
RECHECK_RTOL = 1e-6


@dataclass(frozen=True)
class OperationResult:
    """The robust optimum of one operation.

    Parameters
    ----------
    name, tool : str
        Operation and tool.
    process : {"turning", "milling"}
        Which cutting parameters ``setpoint`` holds.
    setpoint : Mapping[str, float]
        The cutting parameters, in the units their names carry.
    predicted : Mapping[str, Prediction]
        Every model and machine quantity at the setpoint with its band.
    mrr_cm3_min : float
        Removal rate [cm³/min].
    time_min : float
        Machining time ``volume / MRR`` [min].
    binding : tuple[str, ...]
        Quantities whose limit, and parameters whose bound, the optimum sits on.
    """

    name: str
    tool: str
    process: Process
    setpoint: Mapping[str, float]
    predicted: Mapping[str, Prediction]
    mrr_cm3_min: float
    time_min: float
    binding: tuple[str, ...]


@dataclass(frozen=True)
class PlanResult:
    """The robust optimum of every operation of a plan."""

    plan: str
    machine: str
    operations: tuple[OperationResult, ...]

    @property
    def cycle_time_min(self) -> float:
        """Sum of the operations' machining times [min]."""
        return sum(op.time_min for op in self.operations)


class _Program:
    """A DPP cvxpy LP ``max c·x  s.t.  A x <= b,  lo <= x <= hi`` of one shape."""

    def __init__(self, n: int, m: int) -> None:
        self.lock = threading.Lock()
        self.x = cp.Variable(n)
        self.c = cp.Parameter(n)
        self.lo = cp.Parameter(n)
        self.hi = cp.Parameter(n)
        constraints = [self.x >= self.lo, self.x <= self.hi]
        self.A = cp.Parameter((m, n)) if m else None
        self.b = cp.Parameter(m) if m else None
        if self.A is not None:
            constraints.append(self.A @ self.x <= self.b)
        self.problem = cp.Problem(cp.Maximize(self.c @ self.x), constraints)

    def solve(self, lp: LogLinearProgram) -> tuple[str, np.ndarray[Any, Any] | None]:
        with self.lock:
            self.c.value = np.asarray(lp.objective)
            self.lo.value = np.asarray(lp.lower)
            self.hi.value = np.asarray(lp.upper)
            if self.A is not None and self.b is not None:
                self.A.value = np.array([r.coefficients for r in lp.rows])
                self.b.value = np.array([r.rhs for r in lp.rows])
            try:
                self.problem.solve(solver=cp.HIGHS)
            except cp.error.SolverError as err:
                raise SolverError(f"operation {lp.operation!r}: solver failed ({err})") from err
            x = None if self.x.value is None else np.array(self.x.value)
            return str(self.problem.status), x


@cache
def _program(n: int, m: int) -> _Program:
    return _Program(n, m)


def is_dpp(n: int, m: int) -> bool:
    """Whether the cached program of this shape is DPP (re-solvable without re-compiling)."""
    return bool(_program(n, m).problem.is_dpp())


def optimize_operation(operation: Operation, tool: Tool, machine: Machine) -> OperationResult:
    """Fastest robust setpoint of one operation (max MRR, every limit met at the band edge).

    Raises
    ------
    InfeasibleError
        No parameters within the bounds meet every limit; says which limits conflict.
    SolverError
        The solver gave no optimal status, or the optimum fails the re-check.
    """
    lp = formulate(operation, tool, machine)
    status, x = _program(len(lp.parameters), len(lp.rows)).solve(lp)
    if status == cp.INFEASIBLE:
        raise _diagnose(lp)
    if status != cp.OPTIMAL or x is None:
        raise SolverError(f"operation {operation.name!r}: solver status {status}, not optimal")
    x = np.clip(x, lp.lower, lp.upper)
    setpoint = {p: math.exp(v) for p, v in zip(lp.parameters, x, strict=True)}
    point = {**setpoint, **operation.context}
    predicted = predict_all(tool, point, operation.setpoint_rel_uncertainty)
    _recheck(lp, predicted, setpoint)
    mrr = kinematics.mrr_monomial(operation.process).evaluate(point)
    return OperationResult(
        name=operation.name,
        tool=tool.name,
        process=operation.process,
        setpoint=setpoint,
        predicted=predicted,
        mrr_cm3_min=mrr,
        time_min=operation.volume_mm3 / (1000.0 * mrr),
        binding=_binding(lp, x),
    )


def optimize_plan(plan: Plan) -> PlanResult:
    """Robust optimum of every operation of ``plan`` (see :func:`optimize_operation`)."""
    results = []
    for i, op in enumerate(plan.operations):
        try:
            results.append(optimize_operation(op, plan.tools[op.tool], plan.machine))
        except ModelDomainError as err:
            raise PlanError(f"operations[{i}].{err.field}", err.value, err.reason) from None
    return PlanResult(plan=plan.name, machine=plan.machine.name, operations=tuple(results))


def _binding(lp: LogLinearProgram, x: np.ndarray[Any, Any]) -> tuple[str, ...]:
    names = [r.name for r in lp.rows if r.rhs - float(np.dot(r.coefficients, x)) <= BINDING_TOL]
    for p, v, lo, hi in zip(lp.parameters, x, lp.lower, lp.upper, strict=True):
        if v - lo <= BINDING_TOL or hi - v <= BINDING_TOL:
            names.append(p)
    return tuple(names)


def _recheck(
    lp: LogLinearProgram, predicted: Mapping[str, Prediction], setpoint: Mapping[str, float]
) -> None:
    """Refuse an optimum that the models say breaks a limit (beyond solver tolerance)."""
    for row in lp.rows:
        p = predicted[row.name]
        if row.sense == "max":
            ok = p.upper <= row.limit * (1 + RECHECK_RTOL)
            edge = p.upper
        else:
            ok = p.lower >= row.limit * (1 - RECHECK_RTOL)
            edge = p.lower
        if not ok:
            raise SolverError(
                f"operation {lp.operation!r}: optimum {dict(setpoint)} fails the re-check: "
                f"{row.name} at the band edge is {edge:.6g}, limit {row.limit:.6g}"
            )


def _diagnose(lp: LogLinearProgram) -> InfeasibleError:
    """Elastic LP: the least total ln-violation of the rows within the bounds."""
    n, m = len(lp.parameters), len(lp.rows)
    x, s = cp.Variable(n), cp.Variable(m, nonneg=True)
    A = np.array([r.coefficients for r in lp.rows])
    b = np.array([r.rhs for r in lp.rows])
    problem = cp.Problem(
        cp.Minimize(cp.sum(s)),
        [A @ x <= b + s, x >= np.asarray(lp.lower), x <= np.asarray(lp.upper)],
    )
    problem.solve(solver=cp.HIGHS)
    if problem.status != cp.OPTIMAL or s.value is None or x.value is None:
        return InfeasibleError(lp.operation, (), ("the parameter bounds",))
    conflicts: list[Conflict] = []
    against: list[str] = []
    for row, slack, lhs in zip(lp.rows, s.value, A @ x.value, strict=True):
        if slack > BINDING_TOL:
            factor = math.exp(slack) if row.sense == "max" else math.exp(-slack)
            given = row.limit / row.scale
            conflicts.append(Conflict(row.given_as, given, given * factor, row.sense))
        elif row.rhs - lhs <= BINDING_TOL:
            against.append(row.given_as)
    for p, v, lo, hi in zip(lp.parameters, x.value, lp.lower, lp.upper, strict=True):
        if v - lo <= BINDING_TOL:
            against.append(f"{p} >= {math.exp(lo):.4g}")
        elif hi - v <= BINDING_TOL:
            against.append(f"{p} <= {math.exp(hi):.4g}")
    return InfeasibleError(lp.operation, tuple(conflicts), tuple(against))
