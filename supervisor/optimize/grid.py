"""Setpoints the machine can take: an optimum moved onto the machine's resolution grid.

A control takes each cutting parameter in steps (``[machine.resolution]``,
:mod:`supervisor.inputs.resolution`); the optimum of the continuous program rarely lies on that
grid, and float noise puts it next to a bound (depth ``3.0000000000000004`` with bound 3). Which
way to round is not simply "down": roughness falls with speed (a negative exponent), tool life
falls with speed, so rounding a speed down may break the roughness limit and rounding it up the
tool-life one. The rule, applied to every optimum (band and cone programs alike):

1. *Candidates.* Per parameter, the grid points just below and just above the optimum
   (:func:`supervisor.inputs.resolution.steps_within`: only those within the bounds); one
   point where the optimum is within :data:`SNAP_RTOL` of a grid point (float noise). Every
   combination: at most 2⁴ = 16 points.
2. *Check.* Each candidate against every robust row of the program in ``x = ln(parameters)``:
   linear rows ``a·x <= b`` and cone rows ``a·x + z‖G x + h‖ <= b`` (at ``z − slack_z`` for a
   ``learn`` setpoint kept in force), to :data:`ROW_TOL`.
3. *Best.* Of the candidates that pass, the one with the largest ``ln MRR`` (or the least
   Borangiu cost ``J`` for a productivity operation); ties to the first in order (lower
   grid points first).
4. *Fallback.* Where no candidate passes (a sharp vertex of the rows), the program with every
   row tightened by what one grid step of every parameter can move it is solved:
   ``b − Σ|a_i| s_i − z Σ‖G_i‖ s_i − TIGHTEN_MARGIN``, with ``s_i = ln(1 + step_i/low_i)`` the
   largest ln-step of one grid step within the bounds (:func:`tightened`). Every candidate
   around its optimum then meets every original row, by construction; steps 1-3 pick among
   them. A tightened program that is infeasible means no grid point is proven safe.

The setpoint's predictions, MRR and re-check are then those of the grid point
(:mod:`supervisor.optimize.optimizer`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from models import borangiu_cost
from supervisor.inputs.resolution import grid_value, steps_within
from supervisor.optimize import socp
from supervisor.optimize.program import LogLinearProgram

#: An optimum within this fraction of a step count of a grid point is that point (float noise).
SNAP_RTOL = 1e-9
#: A candidate meets a row ``a·x <= b`` when ``a·x <= b + ROW_TOL`` (ln: 1 ppt, float rounding).
ROW_TOL = 1e-12
#: Extra tightening of the fallback's rows [ln]: twice HiGHS's primal feasibility tolerance.
TIGHTEN_MARGIN = 2e-7


def _levels(value: float, low: float, high: float, step: float) -> list[int]:
    """Step counts of the grid points next to ``value`` within ``[low, high]``."""
    k_low, k_high = steps_within(low, high, step)
    q = value / step
    k = round(q)
    near = [k] if abs(q - k) <= SNAP_RTOL * max(1.0, abs(q)) else [math.floor(q), math.floor(q) + 1]
    return sorted({min(max(c, k_low), k_high) for c in near})


def candidates(
    parameters: Sequence[str],
    values: Sequence[float],
    bounds: Mapping[str, tuple[float, float]],
    resolution: Mapping[str, float],
) -> np.ndarray[Any, Any]:
    """Every combination of the grid points next to ``values``: ``(c, n)`` parameter values."""
    per_parameter = []
    for p, v in zip(parameters, values, strict=True):
        low, high = bounds[p]
        step = resolution[p]
        per_parameter.append([grid_value(k, step) for k in _levels(v, low, high, step)])
    return np.array(list(itertools.product(*per_parameter)), dtype=float)


def meets(lp: LogLinearProgram, points: np.ndarray[Any, Any], slack_z: float = 0.0) -> Any:
    """Which rows of ``points`` (parameter values, ``(c, n)``) meet every row of ``lp``."""
    x = np.log(points)
    ok = np.ones(len(points), dtype=bool)
    for row in lp.rows:
        lhs = x @ np.asarray(row.coefficients, dtype=float)
        if row.cone is not None:
            spread = np.linalg.norm(x @ row.cone.G.T + row.cone.h, axis=1)
            lhs = lhs + (row.cone.z - slack_z) * spread
        ok &= lhs <= row.rhs + ROW_TOL
    return ok


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
    steps = np.array([math.log1p(resolution[p] / bounds[p][0]) for p in lp.parameters], dtype=float)
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
