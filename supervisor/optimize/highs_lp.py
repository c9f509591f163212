"""One operation's log-linear program solved by HiGHS through highspy, without cvxpy.

The robust max-MRR program (:mod:`supervisor.optimize.formulation`, Ivester & Heigel Eqs. 10-13 in
logarithms) is already in the standard form HiGHS reads: ``max c·x  s.t.  A x <= b, lo <= x <= hi``.
It is handed to HiGHS as it is, so nothing is formulated twice. The elastic LP of the infeasibility
diagnosis (:mod:`supervisor.optimize.optimizer`) has the same form and goes to HiGHS the same way,
through :func:`solve_lp`.

Why not through cvxpy's parametrised (DPP) program: on this project's 2-core machines a cvxpy
re-solve of a 3-variable LP costs 1-3 ms, nearly all of it cvxpy's per-call work (parameter
stuffing through scipy.sparse and building a new HiGHS model), while HiGHS itself takes a
tenth of that; ``benchmarks/solve_speed.py`` prints both. The re-solve between parts (RCB,
the REST service, the closed-loop benchmark) is the hot path. cvxpy still solves what needs a
modelling layer: Borangiu's geometric program (:mod:`supervisor.borangiu.productivity`); the tests
check this solver against a cvxpy formulation of the same program.

Each thread keeps one HiGHS instance and passes it a new model per solve; the solver state
is cleared first, so a solve never depends on what was solved before.
"""

from __future__ import annotations

import threading
from typing import Any, Literal

import highspy
import numpy as np
from highspy._core import _Highs  # the binding itself, typed; see _highs()
from numpy.typing import ArrayLike

from supervisor.optimize.program import LogLinearProgram

Status = Literal["optimal", "infeasible", "failed"]

_INFEASIBLE = (
    highspy.HighsModelStatus.kInfeasible,
    highspy.HighsModelStatus.kUnboundedOrInfeasible,
)

_local = threading.local()


def _highs() -> _Highs:
    """The calling thread's HiGHS instance (quiet; simplex without presolve, the LPs are tiny).

    It is the pybind11 binding ``_Highs``, not ``highspy.Highs``: the latter's ``__init__``
    enables callbacks, which prints HiGHS's banner to the process's C-level stdout before
    ``output_flag`` can be turned off (it must be off before any other call, HiGHS issue
    #1702), and that banner broke ``rcb ... --json``. Nothing here uses callbacks.
    """
    highs: _Highs | None = getattr(_local, "highs", None)
    if highs is None:
        highs = _Highs()
        highs.setOptionValue("output_flag", False)  # first call: no banner, no log
        highs.setOptionValue("presolve", "off")
        _local.highs = highs
    return highs


def _model(
    cost: ArrayLike,
    a: ArrayLike,
    b: ArrayLike,
    lower: ArrayLike,
    upper: ArrayLike,
    *,
    sense: highspy.ObjSense,
) -> highspy.HighsLp:
    """A HiGHS model: ``cost·x`` in ``sense``, rows ``-inf <= a x <= b``, ``lower <= x <= upper``.

    ``a`` is dense, ``m × n``; HiGHS gets it row-wise without its zeros.
    """
    col_cost = np.asarray(cost, dtype=float)
    n = col_cost.size
    dense = np.asarray(a, dtype=float).reshape(-1, n)
    m = dense.shape[0]
    model = highspy.HighsLp()
    model.num_col_ = n
    model.num_row_ = m
    model.sense_ = sense
    model.col_cost_ = col_cost
    model.col_lower_ = np.asarray(lower, dtype=float)
    model.col_upper_ = np.asarray(upper, dtype=float)
    model.row_lower_ = np.full(m, -highspy.kHighsInf)
    model.row_upper_ = np.asarray(b, dtype=float).reshape(m)
    rows, cols = np.nonzero(dense)  # row-major order: HiGHS takes no explicit zeros
    matrix = model.a_matrix_
    matrix.format_ = highspy.MatrixFormat.kRowwise
    matrix.num_col_ = n
    matrix.num_row_ = m
    matrix.start_ = np.searchsorted(rows, np.arange(m + 1)).astype(np.int32)
    matrix.index_ = cols.astype(np.int32)
    matrix.value_ = dense[rows, cols]
    return model


def solve_lp(
    cost: ArrayLike,
    a: ArrayLike,
    b: ArrayLike,
    lower: ArrayLike,
    upper: ArrayLike,
    *,
    maximize: bool,
    presolve: bool = False,
) -> tuple[Status, Any]:
    """Solve ``max`` (or ``min``) ``cost·x  s.t.  a x <= b,  lower <= x <= upper``.

    Parameters
    ----------
    cost : array_like
        Objective coefficients, one per variable (``n``).
    a : array_like
        Dense ``m × n`` row coefficients (``m`` may be 0).
    b : array_like
        Right-hand sides, one per row.
    lower, upper : array_like
        Variable bounds; ``±highspy.kHighsInf`` for none.
    maximize : bool
        Maximise ``cost·x`` if true, else minimise it.
    presolve : bool
        Run HiGHS's presolve first (a second opinion); off otherwise.

    Returns
    -------
    tuple
        ``("optimal", x)`` with ``x`` a float array of the ``n`` variables, a HiGHS simplex
        vertex; ``("infeasible", None)`` when no point meets every row within the bounds;
        ``("failed", None)`` for any other outcome (HiGHS's status is not an answer to trust).
    """
    sense = highspy.ObjSense.kMaximize if maximize else highspy.ObjSense.kMinimize
    highs = _highs()
    highs.passModel(_model(cost, a, b, lower, upper, sense=sense))
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


def maximize(lp: LogLinearProgram, *, presolve: bool = False) -> tuple[Status, Any]:
    """Solve ``max objective·x`` under ``lp``'s rows and bounds.

    Returns ``("optimal", x)`` with ``x`` the ln-parameters (a float array in
    ``lp.parameters`` order), ``("infeasible", None)`` when no point meets every row within
    the bounds, and ``("failed", None)`` for any other outcome (HiGHS's status is not an
    answer to trust). ``presolve`` runs HiGHS's presolve first (a second opinion). A program
    with cone rows goes to :func:`supervisor.optimize.socp.maximize` instead.
    """
    if any(r.cone is not None for r in lp.rows):
        raise ValueError(f"operation {lp.operation!r}: cone rows need supervisor.optimize.socp")
    return solve_lp(
        lp.objective,
        [r.coefficients for r in lp.rows],
        [r.rhs for r in lp.rows],
        lp.lower,
        lp.upper,
        maximize=True,
        presolve=presolve,
    )
