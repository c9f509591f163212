r"""Whole passes: the pass count and depths that cut an operation's stock in the least time.

An operation with ``stock_mm`` (:mod:`supervisor.inputs.passes`) is cut in ``n`` equal passes
of depth ``d_n = S / n`` (turning: ``depth_mm``; milling: ``axial_depth_mm``), or in ``n − 1``
equal roughing passes of ``(S − d_f)/(n − 1)`` and one finishing pass of ``d_f`` under its own
limits. The operation's ``volume_mm3`` is its whole volume; a pass removes the share of it
its depth is of the stock, ``V·d/S``, so the passes of one kind take

.. math::

    t = \frac{V \, c \, d / S}{1000 \; \mathrm{MRR}(d, x)}
      = \frac{V \, c}{1000 \, S \; R(x)}, \qquad \mathrm{MRR} = d \cdot R(x)

for ``c`` passes at depth ``d`` and the other parameters ``x`` (``R = f·v`` turning,
``ae·fz·z·n/1000`` milling: DESIGN.md's MRR with the depth taken out). For turning this is
exact under the MRR model whatever each pass's own volume (an outer pass of an OD removes
more than an inner one, at the same ``d·f·v``): the times of the passes add up to ``V /
MRR``. With the depth fixed, each ``n`` is the operation's own log-linear program (Ivester &
Heigel Eqs. 10-13) with the depth bound ``[d_n, d_n]``: one LP (one cone program per ``n``
with ``learn``), so every pass keeps every robust constraint. The tool-life row keeps the
operation's whole volume for every kind of pass: the edge's wear fractions ``V_k / mr(x_k)``
then add up to at most ``V / min_k mr(x_k)``, so the requirement holds for the mix.

The search: the depths any setpoint allows, ``[d_lo, d_hi]`` (two LPs, ``min`` and ``max
ln d``), give the counts worth solving, ``ceil(S/d_hi) .. floor(S/d_lo)``, capped at
:data:`~supervisor.inputs.passes.MAX_PASSES`; ``R_max``, the largest ``R`` any depth allows
(one LP), bounds every count's time from below, ``t(n) >= V n / (1000 S R_max)``, so the
counts are solved from the fewest up and the search stops where that bound passes the best
time. The least time wins, the fewer passes on a tie (within :data:`TIE_RTOL`).

Since each count is the continuous program restricted to one depth, the chosen time is never
below the continuous optimum; and where the depth is a monotone constraint (every maximum
rises with depth), it is never above the continuous optimum rounded up to whole passes.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import replace

import numpy as np

from models import kinematics
from models.tool import Tool
from supervisor.errors import InfeasibleError
from supervisor.inputs.passes import DEPTH, DEPTH_RTOL, MAX_PASSES
from supervisor.inputs.plan import Machine, Operation
from supervisor.optimize import socp
from supervisor.optimize.formulation import formulate
from supervisor.optimize.learned import LearnedCone
from supervisor.optimize.program import LogLinearProgram
from supervisor.optimize.result import OperationResult, Passes, PassGroup
from supervisor.optimize.solve import solve

#: One operation's robust optimum (the optimiser's, with the operation's cones if any).
SolveOne = Callable[[Operation], OperationResult]

#: Two counts whose times differ by less than this fraction tie: the fewer passes win.
TIE_RTOL = 1e-9
#: The lower bound of a count's time must pass the best time by this much to stop the
#: search (``R_max`` is an LP optimum, exact to the solver's tolerance).
PRUNE_RTOL = 1e-6
#: The depths the range LPs give are widened by this fraction before they are turned into
#: counts of passes (HiGHS's feasibility tolerance is about 1e-7 in ``ln``).
RANGE_RTOL = 1e-6
#: Quantities a part report measures on the finished surface: the finishing pass's.
FINISH_QUANTITIES = ("roughness_um",)


def roughing_pass(operation: Operation, count: int) -> Operation:
    """The operation as one of ``count`` equal roughing passes: its depth fixed."""
    spec = operation.passes
    assert spec is not None
    return _at_depth(operation, spec.roughing_stock_mm / count, operation.limits)


def finishing_pass(operation: Operation) -> Operation:
    """The operation as its finishing pass: its depth and its limits."""
    assert operation.passes is not None and operation.passes.finish is not None
    finish = operation.passes.finish
    return _at_depth(operation, finish.depth_mm, finish.limits)


def _at_depth(operation: Operation, depth_mm: float, limits: Mapping[str, float]) -> Operation:
    depth = DEPTH[operation.process]
    bounds = {**operation.bounds, depth: (depth_mm, depth_mm)}
    return replace(operation, bounds=bounds, limits=dict(limits), passes=None)


def group_time_min(operation: Operation, count: int, depth_mm: float, mrr_cm3_min: float) -> float:
    """Time of ``count`` passes of ``depth_mm`` at ``mrr_cm3_min``: volume ``V·c·d/S`` [min]."""
    assert operation.passes is not None
    share = count * depth_mm / operation.passes.stock_mm
    return kinematics.machining_time_min(operation.volume_mm3 * share, mrr_cm3_min)


def optimize_passes(
    operation: Operation,
    tool: Tool,
    machine: Machine,
    solve_one: SolveOne,
    cones: Mapping[str, LearnedCone] | None = None,
) -> OperationResult:
    """The fastest whole number of passes of ``operation``'s stock, and their setpoints.

    ``solve_one`` is the optimiser's robust optimum of one operation (with ``cones``, the
    ``learn`` state's, which the search's range programs use as well).

    Returns
    -------
    OperationResult
        The roughing passes' setpoint and predictions, the whole operation's time, and in
        ``passes`` every kind of pass with its count, depth and setpoint.

    Raises
    ------
    InfeasibleError
        No count of passes meets every limit (the finishing pass's limits for a finish).
    """
    spec = operation.passes
    assert spec is not None
    depth = DEPTH[operation.process]
    groups: list[PassGroup] = []
    if spec.finish is not None:
        try:
            last = solve_one(finishing_pass(operation))
        except InfeasibleError as err:
            held = (*err.against, f"the finishing pass at {depth} = {spec.finish.depth_mm:g}")
            raise InfeasibleError(operation.name, err.conflicts, held) from None
        time = group_time_min(operation, 1, spec.finish.depth_mm, last.mrr_cm3_min)
        binding = tuple(b for b in last.binding if b != depth)  # the depth is the plan's
        last = replace(last, time_min=time, binding=binding, fallback=None)
        groups.append(PassGroup("finishing", 1, spec.finish.depth_mm, last))
    count, rough = best_roughing(operation, tool, machine, solve_one, cones)
    d = spec.roughing_stock_mm / count
    lo, hi = operation.bounds[depth]
    at_bound = math.isclose(d, lo, rel_tol=DEPTH_RTOL) or math.isclose(d, hi, rel_tol=DEPTH_RTOL)
    rough = replace(
        rough,
        binding=tuple(b for b in rough.binding if b != depth or at_bound),
        time_min=group_time_min(operation, count, d, rough.mrr_cm3_min),
        fallback=None,
    )
    groups.insert(0, PassGroup("roughing", count, d, rough))
    total = sum(g.result.time_min for g in groups)
    return replace(
        rough,
        mrr_cm3_min=operation.volume_mm3 / (1000.0 * total),
        time_min=total,
        passes=Passes(spec.stock_mm, count + len(groups) - 1, tuple(groups)),
    )


def best_roughing(
    operation: Operation,
    tool: Tool,
    machine: Machine,
    solve_one: SolveOne,
    cones: Mapping[str, LearnedCone] | None = None,
) -> tuple[int, OperationResult]:
    """The count of equal roughing passes with the least time, and its optimum (module doc)."""
    spec = operation.passes
    assert spec is not None
    stock = spec.roughing_stock_mm
    first, last, r_max = search_range(operation, tool, machine, cones)
    best: tuple[float, int, OperationResult] | None = None
    for n in range(first, last + 1):
        bound = operation.volume_mm3 * (stock / spec.stock_mm) * n / (1000.0 * stock * r_max)
        if best is not None and bound > best[0] * (1 + PRUNE_RTOL):
            break
        try:
            result = solve_one(roughing_pass(operation, n))
        except InfeasibleError:
            continue  # a depth between feasible ones may not be (a learned cone's gap)
        time = group_time_min(operation, n, stock / n, result.mrr_cm3_min)
        if best is None or time < best[0] * (1 - TIE_RTOL):
            best = (time, n, result)
    if best is None:
        raise InfeasibleError(
            operation.name, (), (f"stock_mm = {spec.stock_mm:g} in {first}-{last} whole passes",)
        )
    return best[1], best[2]


def search_range(
    operation: Operation,
    tool: Tool,
    machine: Machine,
    cones: Mapping[str, LearnedCone] | None = None,
) -> tuple[int, int, float]:
    """The counts of roughing passes worth solving, and ``R_max`` [cm³/min per mm of depth].

    Raises
    ------
    InfeasibleError
        No depth meets every limit (the band program's diagnosis), or no whole count of
        passes falls among the depths that do.
    """
    spec = operation.passes
    assert spec is not None
    stock = spec.roughing_stock_mm
    depth = DEPTH[operation.process]
    programs = [formulate(operation, tool, machine)]
    usable = {q: c for q, c in (cones or {}).items() if q in tool.models}
    if usable:
        programs.append(formulate(operation, tool, machine, usable))
    k = programs[0].parameters.index(depth)
    unit = np.zeros(len(programs[0].parameters))
    unit[k] = 1.0
    rest = np.array(programs[0].objective)
    rest[k] = 0.0
    directions = (unit, -unit, rest)  # the largest depth, the least, the largest R
    points: list[np.ndarray] = []
    infeasible: InfeasibleError | None = None
    for i, lp in enumerate(programs):
        try:
            found = [_maximize(replace(lp, objective=tuple(c)), i == 0) for c in directions]
        except InfeasibleError as err:  # the band program's: the cones may still hold
            infeasible = err
            continue
        if all(x is not None for x in found):
            points.append(np.array(found))
    if not points:
        assert infeasible is not None  # a band program is always solved
        raise infeasible
    d_hi = max(math.exp(p[0][k]) for p in points)
    d_lo = min(math.exp(p[1][k]) for p in points)
    ln_r = max(float(np.dot(rest, p[2])) for p in points)
    mrr = kinematics.mrr_monomial(operation.process).fix(operation.context)
    r_max = mrr.coefficient * math.exp(ln_r)
    # widened by the LPs' tolerance (a count at the edge is solved: its own LP decides),
    # never beyond the depth bounds
    low, high = operation.bounds[depth]
    first = max(1, math.ceil(stock / d_hi * (1 - RANGE_RTOL)), _fewest(stock, high))
    last = min(MAX_PASSES, math.floor(stock / d_lo * (1 + RANGE_RTOL)), _most(stock, low))
    if first > last:
        held = f"stock_mm = {spec.stock_mm:g}: depths of {d_lo:.4g}-{d_hi:.4g} mm meet the limits"
        raise InfeasibleError(operation.name, (), (f"{held}, no whole count of passes cuts it",))
    return first, last, r_max


def _fewest(stock: float, high: float) -> int:
    """The fewest passes of at most ``high`` deep (to :data:`DEPTH_RTOL`)."""
    return math.ceil(stock / high * (1 - DEPTH_RTOL))


def _most(stock: float, low: float) -> int:
    """The most passes of at least ``low`` deep (to :data:`DEPTH_RTOL`)."""
    return math.floor(stock / low * (1 + DEPTH_RTOL))


def _maximize(lp: LogLinearProgram, band: bool) -> np.ndarray | None:
    """The band program's optimum (its infeasibility raised), or a cone program's (or None)."""
    if band:
        return solve(lp)
    status, x = socp.maximize(lp)
    return np.clip(x, lp.lower, lp.upper) if status == "optimal" and x is not None else None


def measured_at(
    operation: Operation, result: OperationResult, quantity: str
) -> tuple[Operation, OperationResult]:
    """The pass a part report's ``quantity`` of a multi-pass operation was made at.

    The surface the part leaves with is the last pass's, so a roughness (a quantity of
    :data:`FINISH_QUANTITIES`) is the finishing pass's where there is one; everything else
    (force, spindle load or current, power, tool wear) is read at the roughing passes, which
    cut most of the stock at the largest depth. Returns the pass as an operation (its depth,
    its limits) and its setpoint; an operation in one cut is returned as it is.
    """
    passes = result.passes
    if passes is None or operation.passes is None:
        return operation, result
    group = passes.groups[0]
    if quantity in FINISH_QUANTITIES and passes.groups[-1].kind == "finishing":
        return finishing_pass(operation), passes.groups[-1].result
    return roughing_pass(operation, group.count), group.result
