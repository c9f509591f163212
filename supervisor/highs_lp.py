"""One operation's log-linear program solved by HiGHS through highspy, without cvxpy.

The robust max-MRR program (:mod:`supervisor.formulation`, Ivester & Heigel Eqs. 10-13 in
logarithms) is already in the standard form HiGHS reads: ``max c·x  s.t.  A x <= b,
lo <= x <= hi``. It is handed to HiGHS as it is, so nothing is formulated twice.

Why not through cvxpy's parametrised (DPP) program: on this project's 2-core machines a cvxpy
re-solve of a 3-variable LP costs 1-3 ms, nearly all of it cvxpy's per-call work (parameter
stuffing through scipy.sparse and building a new HiGHS model), while HiGHS itself takes a
tenth of that; ``benchmarks/solve_speed.py`` prints both. The re-solve between parts (RCB,
the REST service, the closed-loop benchmark) is the hot path. cvxpy still solves what needs a
modelling layer: Borangiu's geometric program (:mod:`supervisor.productivity`) and the elastic
infeasibility diagnosis (:mod:`supervisor.optimizer`); the tests check this solver against a
cvxpy formulation of the same program.

Each thread keeps one HiGHS instance and passes it a new model per solve; the solver state
is cleared first, so a solve never depends on what was solved before.
"""

from __future__ import annotations

import threading
from typing import Any, Literal

import highspy
import numpy as np

from supervisor.formulation import LogLinearProgram

Status = Literal["optimal", "infeasible", "failed"]

_INFEASIBLE = (
    highspy.HighsModelStatus.kInfeasible,
    highspy.HighsModelStatus.kUnboundedOrInfeasible,
)

_local = threading.local()


def _highs() -> highspy.Highs:
    """The calling thread's HiGHS instance (quiet; simplex without presolve, the LPs are tiny)."""
    highs: highspy.Highs | None = getattr(_local, "highs", None)
    if highs is None:
        highs = highspy.Highs()  # type: ignore[no-untyped-call]  # highspy ships no stubs here
        highs.silent()
        highs.setOptionValue("presolve", "off")
        _local.highs = highs
    return highs


def _model(lp: LogLinearProgram) -> highspy.HighsLp:
    """``lp`` as a HiGHS model: rows ``-inf <= a·x <= rhs``, bounds, objective maximised."""
    n, m = len(lp.parameters), len(lp.rows)
    model = highspy.HighsLp()
    model.num_col_ = n
    model.num_row_ = m
    model.sense_ = highspy.ObjSense.kMaximize
    model.col_cost_ = np.asarray(lp.objective, dtype=float)
    model.col_lower_ = np.asarray(lp.lower, dtype=float)
    model.col_upper_ = np.asarray(lp.upper, dtype=float)
    model.row_lower_ = np.full(m, -highspy.kHighsInf)
    model.row_upper_ = np.array([r.rhs for r in lp.rows], dtype=float)
    dense = np.array([r.coefficients for r in lp.rows], dtype=float).reshape(m, n)
    rows, cols = np.nonzero(dense)  # row-major order: HiGHS takes no explicit zeros
    matrix = model.a_matrix_
    matrix.format_ = highspy.MatrixFormat.kRowwise
    matrix.num_col_ = n
    matrix.num_row_ = m
    matrix.start_ = np.searchsorted(rows, np.arange(m + 1)).astype(np.int32)
    matrix.index_ = cols.astype(np.int32)
    matrix.value_ = dense[rows, cols]
    return model


def maximize(lp: LogLinearProgram, *, presolve: bool = False) -> tuple[Status, Any]:
    """Solve ``max objective·x`` under ``lp``'s rows and bounds.

    Returns ``("optimal", x)`` with ``x`` the ln-parameters (a float array in
    ``lp.parameters`` order), ``("infeasible", None)`` when no point meets every row within
    the bounds, and ``("failed", None)`` for any other outcome (HiGHS's status is not an
    answer to trust). ``presolve`` runs HiGHS's presolve first (a second opinion).
    """
    highs = _highs()
    highs.passModel(_model(lp))
    highs.clearSolver()
    if presolve:
        highs.setOptionValue("presolve", "on")
    try:
        highs.run()
    finally:
        if presolve:
            highs.setOptionValue("presolve", "off")
    status = highs.getModelStatus()
    if status == highspy.HighsModelStatus.kOptimal:
        return "optimal", np.array(highs.getSolution().col_value, dtype=float)
    if status in _INFEASIBLE:
        return "infeasible", None
    return "failed", None
