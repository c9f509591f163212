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
modelling layer: Borangiu's geometric program (:mod:`supervisor.optimize.productivity`); the tests
check this solver against a cvxpy formulation of the same program.

Each thread keeps one HiGHS instance per coefficient matrix (:func:`maximize`; at most
:data:`MAX_KEPT`): a re-solve of a program whose matrix it holds only updates the costs,
column bounds and right-hand sides (what a band or a limit changes between parts) and clears
the solver, so HiGHS starts from its slack basis as on a fresh instance and the answer is
bit-identical to a fresh solve (``tests/supervisor/test_highs_lp.py`` checks it on random
sequences of programs): no answer depends on the solve before it. Building and passing a new
model cost as much as HiGHS's run (``benchmarks/solve_speed.py``, section 5). Other programs (the
elastic LP, a second opinion with presolve) go to the thread's general instance as a new model.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
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


#: Most coefficient matrices a thread keeps a HiGHS instance for (a plan has a few).
MAX_KEPT = 64


def _new_highs() -> _Highs:
    """A quiet HiGHS instance (simplex without presolve, the LPs are tiny)."""
    highs = _Highs()
    highs.setOptionValue("output_flag", False)  # first call: no banner, no log
    highs.setOptionValue("presolve", "off")
    return highs


def _highs() -> _Highs:
    """The calling thread's HiGHS instance (quiet; simplex without presolve, the LPs are tiny).

    It is the pybind11 binding ``_Highs``, not ``highspy.Highs``: the latter's ``__init__``
    enables callbacks, which prints HiGHS's banner to the process's C-level stdout before
    ``output_flag`` can be turned off (it must be off before any other call, HiGHS issue
    #1702), and that banner broke ``rcb ... --json``. Nothing here uses callbacks.
    """
    highs: _Highs | None = getattr(_local, "highs", None)
    if highs is None:
        highs = _new_highs()
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
    return _result(highs)


@dataclass
class _Kept:
    """A HiGHS instance holding one coefficient matrix, and the data it was last given."""

    highs: _Highs
    cost: tuple[float, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    rhs: tuple[float, ...]
    index: Any  # 0..n-1 and 0..m-1 as int32, for the change calls
    rows: Any
    no_lower: Any  # -inf, the rows' lower sides


def _result(highs: _Highs) -> tuple[Status, Any]:
    status = highs.getModelStatus()
    if status == highspy.HighsModelStatus.kOptimal:
        return "optimal", np.array(highs.getSolution().col_value, dtype=float)
    if status in _INFEASIBLE:
        return "infeasible", None
    return "failed", None


def _kept_solve(
    coefficients: tuple[tuple[float, ...], ...],
    cost: tuple[float, ...],
    rhs: tuple[float, ...],
    lower: tuple[float, ...],
    upper: tuple[float, ...],
) -> tuple[Status, Any]:
    """``max cost·x`` on the thread's instance for ``coefficients``, updated, cleared, run.

    A new instance (built, given the model and kept) where the thread holds none for this
    matrix; one whose run gave no optimum or proof of infeasibility is dropped.
    """
    kept_by: dict[Any, _Kept] | None = getattr(_local, "kept", None)
    if kept_by is None:
        kept_by = _local.kept = {}
    key = (len(cost), coefficients)
    kept = kept_by.get(key)
    if kept is None:
        highs = _new_highs()
        sense = highspy.ObjSense.kMaximize
        highs.passModel(_model(cost, coefficients, rhs, lower, upper, sense=sense))
        n, m = len(cost), len(rhs)
        index = np.arange(n, dtype=np.int32)
        rows = np.arange(m, dtype=np.int32)
        kept = _Kept(highs, cost, lower, upper, rhs, index, rows, np.full(m, -highspy.kHighsInf))
        if len(kept_by) >= MAX_KEPT:
            kept_by.clear()
        kept_by[key] = kept
    else:
        highs = kept.highs
        n = len(cost)
        if cost != kept.cost:
            highs.changeColsCost(n, kept.index, np.array(cost, dtype=float))
            kept.cost = cost
        if lower != kept.lower or upper != kept.upper:
            low, high = np.array(lower, dtype=float), np.array(upper, dtype=float)
            highs.changeColsBounds(n, kept.index, low, high)
            kept.lower, kept.upper = lower, upper
        if rhs != kept.rhs:
            # in the binding, missing from its type stub (highspy 1.16)
            highs.changeRowsBounds(  # type: ignore[attr-defined]
                len(rhs), kept.rows, kept.no_lower, np.array(rhs, dtype=float)
            )
            kept.rhs = rhs
        highs.clearSolver()  # from the slack basis, as a fresh instance: no warm start
    highs.run()
    status, x = _result(highs)
    if status == "failed":
        kept_by.pop(key, None)
    return status, x


def maximize(lp: LogLinearProgram, *, presolve: bool = False) -> tuple[Status, Any]:
    """Solve ``max objective·x`` under ``lp``'s rows and bounds.

    Returns ``("optimal", x)`` with ``x`` the ln-parameters (a float array in
    ``lp.parameters`` order), ``("infeasible", None)`` when no point meets every row within
    the bounds, and ``("failed", None)`` for any other outcome (HiGHS's status is not an
    answer to trust). ``presolve`` runs HiGHS's presolve first (a second opinion, on a new
    model); otherwise the thread's instance for ``lp``'s coefficient matrix is updated
    (module docstring). A program with cone rows goes to
    :func:`supervisor.optimize.socp.maximize` instead.
    """
    rows = lp.rows
    if [r.cone for r in rows].count(None) != len(rows):
        raise ValueError(f"operation {lp.operation!r}: cone rows need supervisor.optimize.socp")
    coefficients = tuple([r.coefficients for r in rows])
    rhs = tuple([r.rhs for r in rows])
    if presolve or not rows:
        return solve_lp(
            lp.objective, coefficients, rhs, lp.lower, lp.upper, maximize=True, presolve=presolve
        )
    return _kept_solve(coefficients, lp.objective, rhs, lp.lower, lp.upper)
