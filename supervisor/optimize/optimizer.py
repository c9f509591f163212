"""The robust optimiser: each operation's log-linear program solved by HiGHS.

The max-MRR program of an operation (:mod:`supervisor.optimize.formulation`) goes to HiGHS directly
(:mod:`supervisor.optimize.highs_lp`, which says why not through cvxpy); re-optimising a plan after
a part is one small LP per operation.

An operation whose objective is Borangiu's productivity cost ``J`` is solved on its own, as
a geometric program under the same rows (:mod:`supervisor.borangiu.productivity`);
:func:`optimize_domain` solves Borangiu's (w, n) problem of one pass both ways
(:mod:`supervisor.borangiu.domain`).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from typing import Any

import cvxpy as cp
import highspy
import numpy as np

from models import kinematics
from models.errors import ModelDomainError
from models.kinematics import Process
from models.powerlaw import Prediction
from models.sensors import TaiCurrentFeedCalibration
from models.tool import Tool, predict_all
from supervisor.borangiu import productivity
from supervisor.borangiu.domain import DomainProblem, DomainResult, domain_point, domain_result
from supervisor.constant_load.setpoint import (
    ConstantLoadSetpoint,
    constant_load_setpoint,
    setup_of,
)
from supervisor.errors import Conflict, InfeasibleError, PlanError, SolverError
from supervisor.inputs.plan import Machine, Operation, Plan
from supervisor.optimize import highs_lp, socp
from supervisor.optimize.formulation import formulate, formulate_domain
from supervisor.optimize.program import LogLinearProgram, Objective, Row
from supervisor.rcb.posterior import Cone, display_model

#: Per operation name, per quantity: the cones of a ``learn`` state (:mod:`.posterior`).
Cones = Mapping[str, Mapping[str, Cone]]

#: A row or bound whose slack in ln-space is below this is binding (1 ppm relative).
BINDING_TOL = 1e-6
#: A re-checked prediction may exceed its limit by at most this fraction (solver tolerance).
RECHECK_RTOL = 1e-6
#: A ``learn`` setpoint in force is kept while it meets its cones at ``z`` less this: the
#: hysteresis that stops a posterior mean's noise from backing a setpoint off and on.
KEEP_SLACK_Z = 0.5
#: The points of "the largest feed rate" are those within this (in ln w) of the LP's optimum.
TIE_TOL = 1e-9


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
    objective : {"mrr", "productivity"}
        What the optimum is for.
    cost_per_kg : float or None
        Borangiu's productivity cost ``J`` at the setpoint [currency/kg], when the operation
        has cost data.
    constant_load : ConstantLoadSetpoint or None
        Reference current and feed limits, for a milling operation under constant-load
        control (Tai et al.; :mod:`supervisor.constant_load.setpoint`).
    robust_by : {"band", "cone"}
        What keeps the setpoint safe: the bands, or the learned models' cones (``learn``);
        with ``cone``, ``predicted`` holds the learned value and the cone's half-width.
    fallback : OperationResult or None
        With ``cone``: the band program's optimum beside it (not compared; a cache).
    tool_models : Tool or None
        The tool a band optimum was solved with (not compared; what the cache is keyed on).
    """

    name: str
    tool: str
    process: Process
    setpoint: Mapping[str, float]
    predicted: Mapping[str, Prediction]
    mrr_cm3_min: float
    time_min: float
    binding: tuple[str, ...]
    objective: Objective = "mrr"
    cost_per_kg: float | None = None
    constant_load: ConstantLoadSetpoint | None = None
    robust_by: str = "band"
    fallback: OperationResult | None = field(default=None, compare=False, repr=False)
    tool_models: Tool | None = field(default=None, compare=False, repr=False)


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


_INFEASIBLE = (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE)


def _solve(lp: LogLinearProgram) -> np.ndarray[Any, Any]:
    """Optimal ln-parameters of the max-MRR program ``lp`` (HiGHS, :mod:`.highs_lp`).

    Raises
    ------
    InfeasibleError
        No point meets every row within the bounds; names the conflicting limits.
    SolverError
        HiGHS gave neither an optimum nor a proof of infeasibility.
    """
    status, x = highs_lp.maximize(lp)
    if status == "failed":  # a second opinion, with presolve
        status, x = highs_lp.maximize(lp, presolve=True)
    if status == "infeasible":
        raise _diagnose(lp)
    if status != "optimal" or x is None:
        raise SolverError(f"operation {lp.operation!r}: solver status {status}, not optimal")
    clipped: np.ndarray[Any, Any] = np.clip(x, lp.lower, lp.upper)
    return clipped


def _minimize_cost(lp: LogLinearProgram) -> np.ndarray[Any, Any]:
    """Optimal ln-parameters of the least ``J`` under ``lp``'s rows (a geometric program).

    Errors as :func:`_solve`.
    """
    status, x = productivity.minimize(lp)
    if status in _INFEASIBLE:
        raise _diagnose(lp)
    if status != cp.OPTIMAL or x is None:
        raise SolverError(f"operation {lp.operation!r}: solver status {status}, not optimal")
    clipped: np.ndarray[Any, Any] = np.clip(x, lp.lower, lp.upper)
    return clipped


def _optimum(lp: LogLinearProgram) -> np.ndarray[Any, Any]:
    """The max-MRR optimum, or the least-``J`` one for a productivity program."""
    return _solve(lp) if lp.goal == "mrr" else _minimize_cost(lp)


def optimize_operation(
    operation: Operation,
    tool: Tool,
    machine: Machine,
    cones: Mapping[str, Cone] | None = None,
    last: OperationResult | None = None,
) -> OperationResult:
    """Robust optimum of one operation (max MRR or least ``J``, every limit at the band edge).

    With ``cones`` (a ``learn`` state's learned models) the cone program is solved too and
    the faster of the two optima is taken: the band program is the proven-safe fallback, so
    a setpoint is never worse than the band optimum, and the plan runs while either holds.
    ``last``: the setpoint in force; where it still meets every learned row at ``z −``
    :data:`KEEP_SLACK_Z` and is faster than the new cone optimum (a posterior mean moves with
    noise), it is kept, so a setpoint backs off only when what was learned says it must.

    Raises
    ------
    InfeasibleError
        No parameters within the bounds meet every limit; says which limits conflict (those
        of the band program).
    SolverError
        The solver gave no optimal status, or the optimum fails the re-check.
    """
    band: OperationResult | None = None
    infeasible: InfeasibleError | None = None
    cached = None if last is None else (last.fallback if last.robust_by == "cone" else last)
    if cached is not None and cached.tool_models == tool and cones:
        band = cached  # the same band program: its optimum is the same
    else:
        lp = formulate(operation, tool, machine)
        try:
            band = _result(operation, tool, lp, _optimum(lp), machine)
        except InfeasibleError as err:
            infeasible = err  # raised below unless the learned program holds
    learned = _learned(operation, tool, machine, cones or {}, last)
    if learned is not None and (band is None or learned.mrr_cm3_min > band.mrr_cm3_min):
        return replace(learned, fallback=band)
    if band is None:
        assert infeasible is not None  # a cached band is never None
        raise infeasible
    return band


def _learned(
    operation: Operation,
    tool: Tool,
    machine: Machine,
    cones: Mapping[str, Cone],
    last: OperationResult | None = None,
) -> OperationResult | None:
    """The optimum under the learned models' cones, or None (no cone, or infeasible)."""
    usable = {q: c for q, c in cones.items() if q in tool.models}
    if not usable or operation.objective != "mrr":
        return None
    lp = formulate(operation, tool, machine, usable)
    status, x = socp.maximize(lp)
    if status != "optimal" or x is None:  # no learned optimum: the band program's holds
        return None
    x = np.clip(x, lp.lower, lp.upper)
    slack_z = 0.0
    if last is not None and last.robust_by == "cone":
        kept = np.array([math.log(last.setpoint[p]) for p in lp.parameters])
        faster = float(np.dot(lp.objective, kept)) > float(np.dot(lp.objective, x))
        if faster and socp.meets(lp, kept, KEEP_SLACK_Z):
            x = kept  # shown, and re-checked, at the confidence that keeps it
            usable = {q: replace(c, z=c.z - KEEP_SLACK_Z) for q, c in usable.items()}
            slack_z = KEEP_SLACK_Z
    point = {**{p: math.exp(v) for p, v in zip(lp.parameters, x, strict=True)}}
    point.update(operation.context)
    rel = operation.setpoint_rel_uncertainty
    shown = replace(
        tool,
        models={**tool.models, **{q: display_model(c, point, rel) for q, c in usable.items()}},
    )
    return replace(_result(operation, shown, lp, x, machine, slack_z), robust_by="cone")


def optimize_plan(
    plan: Plan,
    tools: Mapping[str, Tool] | None = None,
    previous: tuple[PlanResult, Mapping[str, Tool], Cones] | None = None,
    cones: Cones | None = None,
) -> PlanResult:
    """Robust optimum of every operation of ``plan``.

    Parameters
    ----------
    plan : Plan
        The plan.
    tools : Mapping[str, Tool], optional
        The tool of an operation, by operation name, where its models differ from the plan's
        (RCB keeps a band per operation and quantity; a simulation uses the true models).
    previous : (PlanResult, Mapping[str, Tool], Cones), optional
        An earlier result of ``plan`` and the tools and cones it was solved with: an
        operation whose tool and cones are the same keeps its result there, since an optimum
        depends only on the operation, its tool, its cones and the machine (DESIGN.md, RCB
        step 4: re-optimise the operations whose bands changed).
    cones : Cones, optional
        Per operation, the learned models' cones (``learn``; :func:`optimize_operation`).

    Errors as :func:`optimize_operation`; a model that cannot be evaluated for an operation's
    inputs is a :class:`PlanError` naming ``operations[i].<field>``.
    """
    overrides = tools or {}
    learned = cones or {}
    used = [overrides.get(op.name) or plan.tools[op.tool] for op in plan.operations]
    kept: dict[str, OperationResult] = {}
    earlier_results: dict[str, OperationResult] = {}
    if previous is not None:
        result, solved_with, cones_with = previous
        earlier = earlier_results = {r.name: r for r in result.operations}
        kept = {
            op.name: earlier[op.name]
            for op, tool in zip(plan.operations, used, strict=True)
            if op.name in earlier
            and solved_with.get(op.name) == tool
            and cones_with.get(op.name) == learned.get(op.name)
        }
    if not learned:  # the band programs alone: formulate all, then solve (errors name fields)
        lps: dict[int, LogLinearProgram] = {}
        for i, (op, tool) in enumerate(zip(plan.operations, used, strict=True)):
            if op.name not in kept:
                with _fields_of(i):
                    lps[i] = formulate(op, tool, plan.machine)
        xs = {i: _optimum(lp) for i, lp in lps.items()}
    results = []
    for i, (op, tool) in enumerate(zip(plan.operations, used, strict=True)):
        if op.name in kept:
            results.append(kept[op.name])
            continue
        with _fields_of(i):
            if learned:
                last = earlier_results.get(op.name)
                results.append(
                    optimize_operation(op, tool, plan.machine, learned.get(op.name), last)
                )
            else:
                results.append(_result(op, tool, lps[i], xs[i], plan.machine))
    return PlanResult(plan=plan.name, machine=plan.machine.name, operations=tuple(results))


@contextmanager
def _fields_of(index: int) -> Iterator[None]:
    """Name a model-domain error by the plan field it comes from."""
    try:
        yield
    except ModelDomainError as err:
        raise PlanError(f"operations[{index}].{err.field}", err.value, err.reason) from None


def _result(
    operation: Operation,
    tool: Tool,
    lp: LogLinearProgram,
    x: np.ndarray[Any, Any],
    machine: Machine,
    slack_z: float = 0.0,
) -> OperationResult:
    """Predictions, re-check and timing at the optimum ``x`` (ln-parameters) of ``lp``.

    ``slack_z``: cone rows hold at ``z − slack_z`` (a learn setpoint kept in force).
    """
    setpoint = {p: math.exp(v) for p, v in zip(lp.parameters, x, strict=True)}
    point = {**setpoint, **operation.context}
    predicted = predict_all(tool, point, operation.setpoint_rel_uncertainty)
    _recheck(lp, predicted, point)
    mrr = kinematics.mrr_monomial(operation.process).evaluate(point)
    return OperationResult(
        name=operation.name,
        tool=tool.name,
        process=operation.process,
        setpoint=setpoint,
        predicted=predicted,
        mrr_cm3_min=mrr,
        time_min=kinematics.machining_time_min(operation.volume_mm3, mrr),
        binding=_binding(lp, x, slack_z),
        objective=lp.goal,
        cost_per_kg=productivity.evaluate(lp.cost, setpoint) if lp.cost else None,
        constant_load=constant_load_of(operation, machine, setpoint),
        tool_models=tool,
    )


def constant_load_of(
    operation: Operation, machine: Machine, setpoint: Mapping[str, float]
) -> ConstantLoadSetpoint | None:
    """Reference current and feed limits of a constant-load milling setpoint (else None)."""
    config = operation.constant_load
    if config is None:
        return None
    calibration = machine.calibrations[config.calibration]
    assert isinstance(calibration, TaiCurrentFeedCalibration)  # the plan reader checks
    point = {**setpoint, **operation.context}
    programmed = kinematics.feed_rate_monomial(operation.process).evaluate(point)
    return constant_load_setpoint(setup_of(config, calibration), programmed)


def optimize_domain(problem: DomainProblem) -> DomainResult:
    """Borangiu's (w, n) problem of one pass: the largest feed rate and the least ``J``.

    The largest ``w`` is an LP (the largest MRR at the pass's depth and width). Where several
    ``n`` give it, the least ``n`` is taken (a second LP with ``w >= w_max``): ``J`` rises with
    ``n`` at fixed ``w`` (its exponents ``(1−q)/m`` and ``1−yp`` are positive), so that is the
    cheapest of the fastest points and ``J`` at "the max-MRR point" is defined. The least ``J``
    is the geometric program under the same rows. Both points are re-checked.

    Raises
    ------
    InfeasibleError
        The constraints cannot all be met; names those that conflict.
    SolverError
        No optimal status, or an optimum fails the re-check.
    """
    lp = formulate_domain(problem)
    fastest = _solve(lp)
    ln_w = float(fastest[0]) - TIE_TOL
    at_fastest = Row(lp.parameters[0], (-1.0, 0.0), -ln_w, math.exp(ln_w), "min", lp.parameters[0])
    slowest_spindle = replace(lp, objective=(0.0, -1.0), rows=(*lp.rows, at_fastest))
    tied = _solve(slowest_spindle)
    points = []
    for x in (tied, _minimize_cost(lp)):
        point = {p: math.exp(v) for p, v in zip(lp.parameters, x, strict=True)}
        _recheck(lp, {}, point)
        points.append(domain_point(problem, point, _binding(lp, x)))
    return domain_result(problem, points[0], points[1])


def _binding(
    lp: LogLinearProgram, x: np.ndarray[Any, Any], slack_z: float = 0.0
) -> tuple[str, ...]:
    """Rows and bounds ``x`` sits on; a cone row with its spread at ``z − slack_z``."""
    names = []
    for r in lp.rows:
        lhs = float(np.dot(r.coefficients, x))
        tol = BINDING_TOL
        if r.cone is not None:  # solved against rhs − CONE_MARGIN
            lhs += (r.cone.z - slack_z) * float(np.linalg.norm(r.cone.G @ x + r.cone.h))
            tol += socp.CONE_MARGIN
        if r.rhs - lhs <= tol:
            names.append(r.name)
    for p, v, lo, hi in zip(lp.parameters, x, lp.lower, lp.upper, strict=True):
        if v - lo <= BINDING_TOL or hi - v <= BINDING_TOL:
            names.append(p)
    return tuple(dict.fromkeys(names))  # a learned quantity has a row per edge age


def _recheck(
    lp: LogLinearProgram, predicted: Mapping[str, Prediction], point: Mapping[str, float]
) -> None:
    """Refuse an optimum that the models say breaks a limit (beyond solver tolerance).

    ``point`` holds the parameters and the context; a row that no model predicts is checked
    with its own monomial.
    """
    setpoint = {p: point[p] for p in lp.parameters}
    for row in lp.rows:
        if row.check is not None:
            value = row.check.evaluate(point)
            p = Prediction(value, 0.0)
        else:
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
    """Elastic LP: the least total ln-violation of the rows within the bounds.

    ``min sum(s)  s.t.  A x - s <= b,  lower <= x <= upper,  s >= 0``, solved by HiGHS
    directly (:func:`.highs_lp.solve_lp`, a simplex vertex).
    """
    n, m = len(lp.parameters), len(lp.rows)
    if m == 0:  # only bounds, and those were checked low <= high
        return InfeasibleError(lp.operation, (), ("the parameter bounds",))
    A = np.array([r.coefficients for r in lp.rows])
    status, xs = highs_lp.solve_lp(
        np.concatenate([np.zeros(n), np.ones(m)]),
        np.hstack([A, -np.eye(m)]),
        [r.rhs for r in lp.rows],
        np.concatenate([lp.lower, np.zeros(m)]),
        np.concatenate([lp.upper, np.full(m, highspy.kHighsInf)]),
        maximize=False,
    )
    if status != "optimal" or xs is None:
        return InfeasibleError(lp.operation, (), ("the parameter bounds",))
    x, slacks = xs[:n], xs[n:]
    # Every row the elastic optimum must relax conflicts, however little: the main solve
    # already found the program infeasible. If round-off hides them all, name the largest.
    violated = slacks > 1e-12
    if not violated.any():
        violated = slacks == slacks.max()
    conflicts: list[Conflict] = []
    against: list[str] = []
    for row, slack, lhs, bad in zip(lp.rows, slacks, A @ x, violated, strict=True):
        if bad:
            given = row.limit / row.scale
            # in logarithms: a limit as tiny as 5e-324 needs a slack whose exp overflows
            log_required = math.log(given) + (slack if row.sense == "max" else -slack)
            required = math.exp(min(log_required, 709.0))
            conflicts.append(Conflict(row.given_as, given, required, row.sense))
        elif row.rhs - lhs <= BINDING_TOL:
            against.append(row.given_as)
    for p, v, lo, hi in zip(lp.parameters, x, lp.lower, lp.upper, strict=True):
        if v - lo <= BINDING_TOL:
            against.append(f"{p} >= {math.exp(lo):.4g}")
        elif hi - v <= BINDING_TOL:
            against.append(f"{p} <= {math.exp(hi):.4g}")
    return InfeasibleError(lp.operation, tuple(conflicts), tuple(against))
