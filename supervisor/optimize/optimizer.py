"""The robust optimiser: each operation's log-linear program solved by HiGHS.

The max-MRR program of an operation (:mod:`supervisor.optimize.formulation`) goes to HiGHS directly
(:mod:`supervisor.optimize.highs_lp`, which says why not through cvxpy); re-optimising a plan after
a part is one small LP per operation.

An operation whose objective is Borangiu's productivity cost ``J`` is solved on its own, as
a geometric program under the same rows (:mod:`supervisor.optimize.productivity`);
:func:`optimize_domain` solves Borangiu's (w, n) problem of one pass both ways
(:mod:`models.borangiu_domain`).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import replace
from typing import Any

import numpy as np

from models import borangiu_cost, kinematics
from models.errors import ModelDomainError
from models.sensors import TaiCurrentFeedCalibration
from models.tool import Tool, predict_all
from supervisor.borangiu.problem import DomainProblem
from supervisor.borangiu.result import DomainResult, domain_point, domain_result
from supervisor.constant_load.setpoint import (
    ConstantLoadSetpoint,
    constant_load_setpoint,
    setup_of,
)
from supervisor.errors import InfeasibleError, PlanError, SolverError
from supervisor.inputs.plan import Machine, Operation, Plan
from supervisor.optimize import grid, passes, socp
from supervisor.optimize.formulation import formulate, formulate_domain
from supervisor.optimize.learned import LearnedCone
from supervisor.optimize.program import LogLinearProgram, Row
from supervisor.optimize.result import OperationResult, PlanResult
from supervisor.optimize.solve import (
    binding,
    diagnose,
    minimize_cost,
    optimum,
    recheck,
    solve,
)

#: Per operation name, per quantity: the cones of a ``learn`` state
#: (:mod:`supervisor.rcb.posterior`).
Cones = Mapping[str, Mapping[str, LearnedCone]]

#: A ``learn`` setpoint in force is kept while it meets its cones at ``z`` less this (a new
#: one is chosen at ``z``): the hysteresis that stops a posterior mean's noise from backing a
#: setpoint off and on. At 2 (kept while the posterior puts it 2σ under the limit) a process
#: at 0.95 x the model backed an operation off once in 7200 part-operations (60 seeds x 20
#: parts x 6), against 157 at 0.5, 5 at 1.5; at 3 the kept setpoints ran so near the limit
#: that 3 readings in 14400 raised the 3σ alarm (issue 15; README, "Strategies").
KEEP_SLACK_Z = 2.0
#: ... but never under ``z`` = 1 (the least ``z`` a plan takes): a setpoint kept at a smaller
#: multiple would sit nearer its limit than the setpoint's own uncertainty (at ``z − 2 <= 0``,
#: for a plan at ``z`` = 2, on the posterior mean), and its band could not be shown
#: (:func:`supervisor.rcb.cone.display_model`): the re-check refused it with a SolverError.
KEEP_Z_FLOOR = 1.0
#: The points of "the largest feed rate" are those within this (in ln w) of the LP's optimum.
TIE_TOL = 1e-9


def optimize_operation(
    operation: Operation,
    tool: Tool,
    machine: Machine,
    cones: Mapping[str, LearnedCone] | None = None,
    last: OperationResult | None = None,
) -> OperationResult:
    """Robust optimum of one operation (max MRR or least ``J``, every limit at the band edge).

    With ``cones`` (a ``learn`` state's learned models) the cone program is solved too and
    the faster of the two optima is taken: the band program is the proven-safe fallback, so
    a setpoint is never worse than the band optimum, and the plan runs while either holds.
    ``last``: the setpoint in force; where it still meets every learned row at ``z −``
    :func:`keep_slack_z` and is faster than the new cone optimum (a posterior mean moves with
    noise), it is kept, so a setpoint backs off only when what was learned says it must.

    Raises
    ------
    InfeasibleError
        No parameters within the bounds meet every limit; says which limits conflict (those
        of the band program).
    SolverError
        The solver gave no optimal status, or the optimum fails the re-check.
    """
    if operation.passes is not None:  # stock_mm in whole passes: a program per count
        return passes.optimize_passes(
            operation, tool, machine, lambda op: optimize_operation(op, tool, machine, cones), cones
        )
    band: OperationResult | None = None
    infeasible: InfeasibleError | None = None
    cached = None if last is None else (last.fallback if last.robust_by == "cone" else last)
    if cached is not None and cached.tool_models == tool and cones:
        band = cached  # the same band program: its optimum is the same
    else:
        lp = formulate(operation, tool, machine)
        try:
            band = _band(operation, tool, lp, optimum(lp), machine)
        except InfeasibleError as err:
            infeasible = err  # raised below unless the learned program holds
    learned = _learned(operation, tool, machine, cones or {}, last)
    if learned is not None and (band is None or learned.mrr_cm3_min > band.mrr_cm3_min):
        return replace(learned, fallback=band)
    if band is None:
        assert infeasible is not None  # a cached band is never None
        raise infeasible
    if learned is not None and not _agrees(operation, tool, machine, cones or {}, band):
        return replace(learned, fallback=band)
    return band


def _agrees(
    operation: Operation,
    tool: Tool,
    machine: Machine,
    cones: Mapping[str, LearnedCone],
    band: OperationResult,
) -> bool:
    """Whether the learned models put the band optimum within every limit at their ``veto_z``.

    Where the learned mean says the band optimum is past a limit (the band's exponents
    carry a reading's evidence elsewhere, e.g. after a change of the process), the learned
    optimum is taken though slower: evidence against the model wins (DESIGN.md, RCB). The
    mean, not the cone: the band is the proven fallback, vetoed by what was learned, not by
    what is still uncertain; a fleet whose machines differ by more than the band is evidence
    against it, and vetoes at 2 sd (:mod:`supervisor.fleet.prior`, ``FLEET_VETO_Z``).
    """
    usable = {q: c.at_z(c.veto_z) for q, c in cones.items() if q in tool.models}
    if not usable:
        return True
    lp = formulate(operation, tool, machine, usable)
    x = np.array([math.log(band.setpoint[p]) for p in lp.parameters])
    return socp.meets(lp, x)


def _learned(
    operation: Operation,
    tool: Tool,
    machine: Machine,
    cones: Mapping[str, LearnedCone],
    last: OperationResult | None = None,
) -> OperationResult | None:
    """The optimum under the learned models' cones, or None (no cone, or infeasible)."""
    usable = {q: c for q, c in cones.items() if q in tool.models}
    if not usable or operation.objective != "mrr":
        return None
    lp = formulate(operation, tool, machine, usable)
    x = grid.cone_optimum(lp)
    if x is None:  # no learned optimum: the band program's holds
        return None
    bounds, resolution = operation.bounds, machine.resolution
    slack_z = 0.0
    found = grid.machine_point(lp, x, bounds, resolution, grid.cone_optimum)
    keep_slack = keep_slack_z(min(c.z for c in usable.values()))
    if last is not None and last.robust_by == "cone":
        kept = np.array([math.log(last.setpoint[p]) for p in lp.parameters])
        kept_values = grid.on_grid(lp, kept, bounds, resolution, keep_slack)
        faster = kept_values is not None and (
            found is None or _ln_mrr(lp, kept_values) > _ln_mrr(lp, found[2])
        )
        if faster and kept_values is not None and socp.meets(lp, kept, keep_slack):
            # shown, and re-checked, at the confidence that keeps it
            found = (lp, kept, kept_values)
            usable = {q: c.at_z(c.z - keep_slack) for q, c in usable.items()}
            slack_z = keep_slack
    if found is None:  # no learned grid point is proven safe: the band program's holds
        return None
    held_lp, x_held, values = found
    point = {p: float(v) for p, v in zip(lp.parameters, values, strict=True)}
    point.update(operation.context)
    rel = operation.setpoint_rel_uncertainty
    shown = replace(
        tool,
        models={**tool.models, **{q: c.shown(point, rel) for q, c in usable.items()}},
    )
    held = binding(held_lp, x_held, slack_z)
    return replace(_result(operation, shown, lp, values, held, machine), robust_by="cone")


def keep_slack_z(z: float) -> float:
    """How far under ``z`` a setpoint in force is kept: :data:`KEEP_SLACK_Z`, to ``z`` = 1."""
    return max(min(KEEP_SLACK_Z, z - KEEP_Z_FLOOR), 0.0)


def _ln_mrr(lp: LogLinearProgram, values: np.ndarray[Any, Any]) -> float:
    """``ln MRR`` (the objective, up to a constant) at parameter ``values``."""
    return float(np.asarray(lp.objective, dtype=float) @ np.log(values))


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
    kept, earlier_results = _kept(plan, used, previous, learned)
    if not learned:  # the band programs alone: formulate all, then solve (errors name fields)
        lps: dict[int, LogLinearProgram] = {}
        for i, (op, tool) in enumerate(zip(plan.operations, used, strict=True)):
            if op.name not in kept and op.passes is None:
                with _fields_of(i):
                    lps[i] = formulate(op, tool, plan.machine)
        xs = {i: optimum(lp) for i, lp in lps.items()}
    results = []
    for i, (op, tool) in enumerate(zip(plan.operations, used, strict=True)):
        if op.name in kept:
            results.append(kept[op.name])
            continue
        with _fields_of(i):
            if learned or op.passes is not None:
                last = earlier_results.get(op.name)
                results.append(
                    optimize_operation(op, tool, plan.machine, learned.get(op.name), last)
                )
            else:
                results.append(_band(op, tool, lps[i], xs[i], plan.machine))
    return PlanResult(plan=plan.name, machine=plan.machine.name, operations=tuple(results))


def _kept(
    plan: Plan,
    used: list[Tool],
    previous: tuple[PlanResult, Mapping[str, Tool], Cones] | None,
    learned: Cones,
) -> tuple[dict[str, OperationResult], dict[str, OperationResult]]:
    """The earlier results that still hold, and every earlier result, by operation name.

    An earlier result holds where the operation's tool and cones are those it was solved with
    (DESIGN.md, RCB step 4: re-optimise the operations whose bands changed).
    """
    if previous is None:
        return {}, {}
    result, solved_with, cones_with = previous
    earlier = {r.name: r for r in result.operations}
    kept = {
        op.name: earlier[op.name]
        for op, tool in zip(plan.operations, used, strict=True)
        if op.name in earlier
        and solved_with.get(op.name) == tool
        and cones_with.get(op.name) == learned.get(op.name)
    }
    return kept, earlier


@contextmanager
def _fields_of(index: int) -> Iterator[None]:
    """Name a model-domain error by the plan field it comes from."""
    try:
        yield
    except ModelDomainError as err:
        raise PlanError(f"operations[{index}].{err.field}", err.value, err.reason) from None


#: What holds a program whose continuous optimum has no grid point proven safe nearby.
GRID_HELD = "setpoints on the grid of machine.resolution"


def _band(
    operation: Operation,
    tool: Tool,
    lp: LogLinearProgram,
    x: np.ndarray[Any, Any],
    machine: Machine,
) -> OperationResult:
    """The band program's setpoint: its optimum ``x`` moved onto the machine's grid.

    The rule of :mod:`supervisor.optimize.grid`; ``binding`` names what holds the optimum it
    comes from (the tightened program's, after the fallback).

    Raises
    ------
    InfeasibleError
        The tightened program of the fallback is infeasible (its conflicts, held also by
        :data:`GRID_HELD`).
    """
    bounds, resolution = operation.bounds, machine.resolution
    found = grid.machine_point(lp, x, bounds, resolution, _optimum_or_none)
    if found is None:
        err = diagnose(grid.tightened(lp, bounds, resolution))
        raise InfeasibleError(err.operation, err.conflicts, (*err.against, GRID_HELD))
    held_lp, x, values = found
    return _result(operation, tool, lp, values, binding(held_lp, x), machine)


def _optimum_or_none(lp: LogLinearProgram) -> np.ndarray[Any, Any] | None:
    """:func:`optimum`, None where ``lp`` has none (the grid rule's sub-programs)."""
    try:
        return optimum(lp)
    except (InfeasibleError, SolverError):
        return None


def _result(
    operation: Operation,
    tool: Tool,
    lp: LogLinearProgram,
    values: np.ndarray[Any, Any],
    held: tuple[str, ...],
    machine: Machine,
) -> OperationResult:
    """Predictions, re-check and timing at the grid point ``values`` (``lp.parameters`` order).

    ``held``: the rows and bounds the optimum it comes from sits on.
    """
    setpoint = {p: float(v) for p, v in zip(lp.parameters, values, strict=True)}
    point = {**setpoint, **operation.context}
    predicted = predict_all(tool, point, operation.setpoint_rel_uncertainty)
    recheck(lp, predicted, point)
    mrr = kinematics.mrr_monomial(operation.process).evaluate(point)
    return OperationResult(
        name=operation.name,
        tool=tool.name,
        process=operation.process,
        setpoint=setpoint,
        predicted=predicted,
        mrr_cm3_min=mrr,
        time_min=kinematics.machining_time_min(operation.volume_mm3, mrr),
        binding=held,
        objective=lp.goal,
        cost_per_kg=borangiu_cost.evaluate(lp.cost, setpoint) if lp.cost else None,
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
    fastest = solve(lp)
    ln_w = float(fastest[0]) - TIE_TOL
    at_fastest = Row(lp.parameters[0], (-1.0, 0.0), -ln_w, math.exp(ln_w), "min", lp.parameters[0])
    slowest_spindle = replace(lp, objective=(0.0, -1.0), rows=(*lp.rows, at_fastest))
    tied = solve(slowest_spindle)
    points = []
    for x in (tied, minimize_cost(lp)):
        point = {p: math.exp(v) for p, v in zip(lp.parameters, x, strict=True)}
        recheck(lp, {}, point)
        points.append(domain_point(problem, point, binding(lp, x)))
    return domain_result(problem, points[0], points[1])
