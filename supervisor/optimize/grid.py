"""Setpoints the machine can take: an optimum moved onto the machine's resolution grid.

A control takes each cutting parameter in steps (``[machine.resolution]``,
:mod:`supervisor.inputs.resolution`); the optimum of the continuous program rarely lies on that
grid, and float noise puts it next to a bound (depth ``3.0000000000000004`` with bound 3). Which
way to round is not simply "down": roughness falls with speed (a negative exponent), tool life
falls with speed, so rounding a speed down may break the roughness limit and rounding it up the
tool-life one. The rule, applied to every optimum (band and cone programs alike):

1. *Candidates.* Per parameter, the grid points just below and just above the optimum
   (:func:`supervisor.inputs.resolution.steps_within`: only those within the bounds); one
   point where the optimum is within :data:`SNAP_RTOL` of a grid point (float noise); a
   parameter its bounds fix (a whole pass's depth ``stock / n``) keeps that value, so the
   passes add up to the stock. Every combination: at most 2⁴ = 16 points.
2. *Check.* Each candidate against every robust row of the program in ``x = ln(parameters)``:
   linear rows ``a·x <= b`` and cone rows ``a·x + z‖G x + h‖ <= b`` (at ``z − slack_z`` for a
   ``learn`` setpoint kept in force), to :data:`ROW_TOL`.
3. *Best.* Of the candidates that pass, the one with the largest ``ln MRR`` (or the least
   Borangiu cost ``J`` for a productivity operation); ties to the first in order (lower
   grid points first).
4. *Fix and re-solve.* Where no candidate passes (a sharp vertex of the rows, or a bound
   that is no grid point pushing another parameter more than one step), the parameters are
   fixed one at a time, those farthest (in ln) from their nearest grid point first, so that
   the others can make up for it: each to whichever of its candidates (and the grid points
   :data:`FIX_REACH` steps beyond them) lets the program of the parameters still free reach
   the better optimum (:func:`fix_and_resolve`, at most six solves per parameter). A row in
   fixed parameters alone is decided exactly, not to a solver's tolerance; the last
   parameter's candidates are checked as in step 2 and the best taken as in step 3.
5. *Tightened program.* Where that fails too, the program with every row tightened by what
   one grid step of every parameter can move it is solved:
   ``b − Σ|a_i| s_i − z Σ‖G_i‖ s_i − TIGHTEN_MARGIN``, with ``s_i = ln(1 + step_i/low_i)`` the
   largest ln-step of one grid step within the bounds (:func:`tightened`). Every candidate
   around its optimum then meets every original row, by construction; steps 1-3 pick among
   them. The solver meets a row to its tolerance only: where its optimum passes a tightened
   row (by 2e-7 where a row's exponents sum to 3.5, found by Hypothesis at limits met
   exactly at a corner of bounds off the grid), the rows it passed are tightened again by
   that much, at most :data:`RETIGHTEN` times. A tightened program that is infeasible means
   no grid point is proven safe.

:func:`machine_point` applies the whole rule.

The setpoint's predictions, MRR and re-check are then those of the grid point
(:mod:`supervisor.optimize.optimizer`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from models import borangiu_cost
from supervisor.inputs.resolution import grid_value, steps_within
from supervisor.optimize import socp
from supervisor.optimize.program import LogLinearProgram

#: An optimum within this fraction of its value of a grid point is that point (float noise:
#: 3.0000000000000004 is 3 to 1.5e-16).
SNAP_RTOL = 1e-12
#: A candidate meets a row ``a·x <= b`` when ``a·x <= b + ROW_TOL`` (ln: 1 ppt, float rounding).
ROW_TOL = 1e-12
#: Fix and re-solve tries the grid points up to this many steps beyond the two next to the
#: optimum (an interior-point optimum may lie a solver tolerance outside a row).
FIX_REACH = 2
#: Extra tightening of the fallback's rows [ln]: twice HiGHS's primal feasibility tolerance.
TIGHTEN_MARGIN = 2e-7
#: Times the fallback is tightened again by what its optimum passed its rows by (step 5).
RETIGHTEN = 3


def _levels(value: float, low: float, high: float, step: float, reach: int = 0) -> list[int]:
    """Step counts of the grid points next to ``value`` within ``[low, high]``.

    ``reach``: so many more steps on either side.
    """
    k_low, k_high = steps_within(low, high, step)
    if k_low > k_high:  # no grid point within the bounds (a plan refuses such bounds)
        return []
    q = value / step
    k = round(q)
    if abs(q - k) <= SNAP_RTOL * max(1.0, abs(q)):
        first, last = k, k
    else:
        first, last = math.floor(q), math.floor(q) + 1
    return sorted({min(max(c, k_low), k_high) for c in range(first - reach, last + reach + 1)})


def _points(
    p: str,
    value: float,
    bounds: Mapping[str, tuple[float, float]],
    resolution: Mapping[str, float],
    reach: int = 0,
) -> list[float]:
    """The candidate values of parameter ``p`` next to ``value``.

    Its grid points; for a parameter its bounds fix (a whole pass's depth, ``stock / n``:
    :mod:`supervisor.optimize.passes`), the value they fix it at.
    """
    low, high = bounds[p]
    if low == high:
        return [low]
    return [grid_value(k, resolution[p]) for k in _levels(value, low, high, resolution[p], reach)]


def candidates(
    parameters: Sequence[str],
    values: Sequence[float],
    bounds: Mapping[str, tuple[float, float]],
    resolution: Mapping[str, float],
) -> np.ndarray[Any, Any]:
    """Every combination of the grid points next to ``values``: ``(c, n)`` parameter values."""
    per_parameter = [
        _points(p, v, bounds, resolution) for p, v in zip(parameters, values, strict=True)
    ]
    points = list(itertools.product(*per_parameter))
    return np.array(points, dtype=float).reshape(len(points), len(per_parameter))


def excess(lp: LogLinearProgram, x: np.ndarray[Any, Any], slack_z: float = 0.0) -> Any:
    """How far each point of ``x`` (ln-parameters, ``(c, n)``) passes each row: ``(c, m)``."""
    a = np.array([row.coefficients for row in lp.rows], dtype=float).reshape(len(lp.rows), -1)
    lhs = x @ a.T  # (c, m)
    for j, row in enumerate(lp.rows):
        if row.cone is not None:
            spread = np.linalg.norm(x @ row.cone.G.T + row.cone.h, axis=1)
            lhs[:, j] += (row.cone.z - slack_z) * spread
    return lhs - np.array([row.rhs for row in lp.rows], dtype=float)


def meets(lp: LogLinearProgram, points: np.ndarray[Any, Any], slack_z: float = 0.0) -> Any:
    """Which rows of ``points`` (parameter values, ``(c, n)``) meet every row of ``lp``."""
    if not lp.rows:
        return np.ones(len(points), dtype=bool)
    return np.all(excess(lp, np.log(points), slack_z) <= ROW_TOL, axis=1)


def best(
    lp: LogLinearProgram, points: np.ndarray[Any, Any], slack_z: float = 0.0
) -> np.ndarray[Any, Any] | None:
    """The best candidate of ``points`` that meets every row (None: none does)."""
    feasible = points[meets(lp, points, slack_z)]
    if not len(feasible):
        return None
    if lp.goal == "productivity" and lp.cost:
        costs = [
            borangiu_cost.evaluate(lp.cost, dict(zip(lp.parameters, p, strict=True)))
            for p in feasible
        ]
        chosen: np.ndarray[Any, Any] = feasible[int(np.argmin(costs))]
        return chosen
    scores = np.log(feasible) @ np.asarray(lp.objective, dtype=float)
    chosen = feasible[int(np.argmax(scores))]
    return chosen


def on_grid(
    lp: LogLinearProgram,
    x: np.ndarray[Any, Any],
    bounds: Mapping[str, tuple[float, float]],
    resolution: Mapping[str, float],
    slack_z: float = 0.0,
) -> np.ndarray[Any, Any] | None:
    """The best grid point next to the optimum ``x`` (ln-parameters) of ``lp``, or None.

    Steps 1-3 of the module docstring; the values are in ``lp.parameters`` order.
    """
    values = np.exp(x)
    return best(lp, candidates(lp.parameters, values, bounds, resolution), slack_z)


def tightened(
    lp: LogLinearProgram,
    bounds: Mapping[str, tuple[float, float]],
    resolution: Mapping[str, float],
) -> LogLinearProgram:
    """``lp`` with every row tightened by what one grid step can move it (step 4)."""
    steps = np.array(
        [
            0.0 if bounds[p][0] == bounds[p][1] else math.log1p(resolution[p] / bounds[p][0])
            for p in lp.parameters
        ],
        dtype=float,
    )
    rows = []
    for row in lp.rows:
        shift = float(np.abs(np.asarray(row.coefficients, dtype=float)) @ steps)
        if row.cone is not None:
            column_norms = np.linalg.norm(np.asarray(row.cone.G, dtype=float), axis=0)
            shift += row.cone.z * float(column_norms @ steps)
        rows.append(replace(row, rhs=row.rhs - shift - TIGHTEN_MARGIN))
    return replace(lp, rows=tuple(rows))


def cone_optimum(lp: LogLinearProgram) -> np.ndarray[Any, Any] | None:
    """The optimum of a program with cone rows (Clarabel), clipped to its bounds; None if none."""
    status, x = socp.maximize(lp)
    if status != "optimal" or x is None:
        return None
    clipped: np.ndarray[Any, Any] = np.clip(x, lp.lower, lp.upper)
    return clipped


#: A solver of a program: its optimum (ln-parameters), or None when it has none.
Solve = Callable[[LogLinearProgram], "np.ndarray[Any, Any] | None"]


def _score(lp: LogLinearProgram, x: np.ndarray[Any, Any]) -> float:
    """How good an optimum is: ``ln MRR``, or ``−J`` for a productivity program."""
    if lp.goal == "productivity" and lp.cost:
        setpoint = {p: math.exp(v) for p, v in zip(lp.parameters, x, strict=True)}
        return -borangiu_cost.evaluate(lp.cost, setpoint)
    return float(np.dot(lp.objective, x))


def _fixed_rows_hold(lp: LogLinearProgram, x: Sequence[float], fixed: set[int]) -> bool:
    """Whether the linear rows in the ``fixed`` parameters alone hold at ``x``.

    Exactly (to :data:`ROW_TOL`), not to a solver's tolerance.
    """
    for row in lp.rows:
        a = row.coefficients
        if row.cone is None and all(a[j] == 0 or j in fixed for j in range(len(a))):
            if sum(a[j] * x[j] for j in fixed) > row.rhs + ROW_TOL:
                return False
    return True


def fix_and_resolve(
    lp: LogLinearProgram,
    x: np.ndarray[Any, Any],
    bounds: Mapping[str, tuple[float, float]],
    resolution: Mapping[str, float],
    solve: Solve,
    slack_z: float = 0.0,
) -> np.ndarray[Any, Any] | None:
    """Step 4: fix the parameters on the grid one at a time, re-solving for the others."""
    params = lp.parameters
    gaps = []  # how far (in ln) each parameter must move to reach its nearest grid point
    for p, v in zip(params, x, strict=True):
        near = _points(p, math.exp(v), bounds, resolution)
        if not near:
            return None
        gaps.append(min(abs(math.log(value) - v) for value in near))
    lower, upper = list(lp.lower), list(lp.upper)
    values = np.empty(len(params), dtype=float)
    current = x
    *first, last = sorted(range(len(params)), key=lambda i: (-gaps[i], i))
    fixed: set[int] = set()
    for i in first:
        p = params[i]
        fixed.add(i)
        chosen: tuple[float, np.ndarray[Any, Any], float] | None = None
        for value in _points(p, math.exp(current[i]), bounds, resolution, FIX_REACH):
            lower[i] = upper[i] = math.log(value)
            if not _fixed_rows_hold(lp, lower, fixed):
                continue
            y = solve(replace(lp, lower=tuple(lower), upper=tuple(upper)))
            if y is not None and (chosen is None or _score(lp, y) > chosen[2]):
                chosen = (value, y, _score(lp, y))
        if chosen is None:
            return None
        values[i] = chosen[0]
        lower[i] = upper[i] = math.log(chosen[0])
        current = chosen[1]
    # the last one: its candidates checked against the rows themselves, not a solver's
    # tolerance, and the best that passes taken
    p = params[last]
    points = []
    for value in _points(p, math.exp(current[last]), bounds, resolution, FIX_REACH):
        values[last] = value
        points.append(values.copy())
    return best(lp, np.array(points), slack_z)


def machine_point(
    lp: LogLinearProgram,
    x: np.ndarray[Any, Any],
    bounds: Mapping[str, tuple[float, float]],
    resolution: Mapping[str, float],
    solve: Solve,
) -> tuple[LogLinearProgram, np.ndarray[Any, Any], np.ndarray[Any, Any]] | None:
    """The rule of the module docstring for the optimum ``x`` of ``lp``.

    Returns ``(program, optimum, values)``: the grid point ``values`` (``lp.parameters``
    order) and the program and optimum it comes from (``lp`` and ``x``, or the tightened
    program and its optimum), for the rows it binds; None when no grid point is proven safe.
    """
    values = on_grid(lp, x, bounds, resolution)
    if values is None:
        values = fix_and_resolve(lp, x, bounds, resolution, solve)
    if values is not None:
        return lp, x, values
    tight = tightened(lp, bounds, resolution)
    x_tight = solve(tight)
    for _ in range(RETIGHTEN):
        if x_tight is None or not tight.rows:
            break
        # the solver's tolerance may take back the margin: its optimum past a tightened row
        # (by 2e-7 where a row's exponents sum to 3.5) is tightened by that much again
        passed = np.maximum(excess(tight, x_tight[None, :])[0], 0.0)
        if passed.max() <= ROW_TOL:
            break
        rows = tuple(replace(r, rhs=r.rhs - p) for r, p in zip(tight.rows, passed, strict=True))
        tight = replace(tight, rows=rows)
        x_tight = solve(tight)
    if x_tight is None:
        return None
    values = on_grid(lp, x_tight, bounds, resolution)
    return None if values is None else (tight, x_tight, values)
