"""Solving one log-linear program: its optimum, the rows it binds, its re-check, its diagnosis.

The max-MRR program goes to HiGHS directly (:mod:`supervisor.optimize.highs_lp`), the least-``J``
one to cvxpy as a geometric program (:mod:`supervisor.optimize.productivity`). Only an optimal
status is an answer; the optimum is re-checked against the models (:func:`recheck`), and an
infeasible program is diagnosed by an elastic LP that names the limits in conflict and by how
much (:func:`diagnose`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import highspy
import numpy as np

from models.powerlaw import Prediction
from supervisor.errors import Conflict, InfeasibleError, SolverError
from supervisor.optimize import highs_lp, socp
from supervisor.optimize.program import LogLinearProgram

#: A row or bound whose slack in ln-space is below this is binding (1 ppm relative).
BINDING_TOL = 1e-6
#: A re-checked prediction may exceed its limit by at most this fraction (solver tolerance).
RECHECK_RTOL = 1e-6


def solve(lp: LogLinearProgram) -> np.ndarray[Any, Any]:
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
        raise diagnose(lp)
    if status != "optimal" or x is None:
        raise SolverError(f"operation {lp.operation!r}: solver status {status}, not optimal")
    clipped: np.ndarray[Any, Any] = np.clip(x, lp.lower, lp.upper)
    return clipped


def minimize_cost(lp: LogLinearProgram) -> np.ndarray[Any, Any]:
    """Optimal ln-parameters of the least ``J`` under ``lp``'s rows (a geometric program).

    Errors as :func:`solve`.
    """
    # imported here: cvxpy takes about 0.8 s to import, and only this program needs it
    import cvxpy as cp

    from supervisor.optimize import productivity

    status, x = productivity.minimize(lp)
    if status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
        raise diagnose(lp)
    if status != cp.OPTIMAL or x is None:
        raise SolverError(f"operation {lp.operation!r}: solver status {status}, not optimal")
    clipped: np.ndarray[Any, Any] = np.clip(x, lp.lower, lp.upper)
    return clipped


def optimum(lp: LogLinearProgram) -> np.ndarray[Any, Any]:
    """The max-MRR optimum, or the least-``J`` one for a productivity program."""
    return solve(lp) if lp.goal == "mrr" else minimize_cost(lp)


def binding(lp: LogLinearProgram, x: np.ndarray[Any, Any], slack_z: float = 0.0) -> tuple[str, ...]:
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


def recheck(
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


def diagnose(lp: LogLinearProgram) -> InfeasibleError:
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
