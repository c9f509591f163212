r"""Borangiu's productivity cost ``J`` minimised as a geometric program (DGP) with cvxpy.

``J`` itself, its cost data and coefficients are pure physics, in :mod:`models.borangiu_cost`.
In the main optimiser the depths are free too, so ``J`` is built in the cutting parameters
(``ap, ae, fz, vc``) with ``P_c`` the nominal ``F·v/60000`` of the tool's force model.

Every constraint row of the log-linear program ``a·ln(x) <= rhs`` is the monomial inequality
``e^{-rhs} Π x^a <= 1``, so minimising ``J`` under the same rows is a geometric program. It is
built once per structure (exponents) with positive parameters for the coefficients (DPP) and
solved by cvxpy in ``gp=True`` mode with Clarabel.

References
----------
.. [1] Borangiu et al., Embedded numeric-adaptive machining control based on data fusion,
   IFAC 2007, ``J(w, n)``.
.. [2] cvxpy, disciplined geometric programming (Agrawal, Xu & Boyd, 2019).
"""

from __future__ import annotations

import threading
import warnings
from collections.abc import Mapping, Sequence
from functools import lru_cache, reduce
from typing import Any

import cvxpy as cp
import numpy as np

from supervisor.errors import SolverError
from supervisor.optimize.program import LogLinearProgram

# --- the geometric program -------------------------------------------------------------------

#: (number of variables, exponents of each constraint row, exponents of each cost term)
_Structure = tuple[int, tuple[tuple[float, ...], ...], tuple[tuple[float, ...], ...]]


#: Tighter than Clarabel's defaults (1e-8): J is flat at its minimum, so the argmin is only
#: as good as the square root of the gap. Where they are too tight the defaults are used.
_CLARABEL = {"tol_gap_abs": 1e-10, "tol_gap_rel": 1e-10}


def _monomial(x: Any, exponents: Sequence[float]) -> Any:
    factors = [x[j] if e == 1 else x[j] ** e for j, e in enumerate(exponents) if e != 0]
    return reduce(lambda left, right: left * right, factors) if factors else None


class _CostProgram:
    """``min Σ_k p_k Π x^e_k  s.t.  r_i Π x^a_i <= 1, lo <= x <= hi`` with positive parameters."""

    def __init__(self, structure: _Structure) -> None:
        n, rows, terms = structure
        self.lock = threading.Lock()
        self.x = cp.Variable(n, pos=True)
        self.lo = cp.Parameter(n, pos=True)
        self.hi = cp.Parameter(n, pos=True)
        self.rows = [i for i, a in enumerate(rows) if any(a)]  # a constant row is checked
        self.r = [cp.Parameter(pos=True) for _ in self.rows]
        self.p = [cp.Parameter(pos=True) for _ in terms]
        constraints = [self.x >= self.lo, self.x <= self.hi]
        for r, i in zip(self.r, self.rows, strict=True):
            constraints.append(r * _monomial(self.x, rows[i]) <= 1)
        parts = []
        for p, e in zip(self.p, terms, strict=True):
            monomial = _monomial(self.x, e)
            parts.append(p if monomial is None else p * monomial)
        self.problem = cp.Problem(cp.Minimize(reduce(lambda s, t: s + t, parts)), constraints)

    def solve(self, lp: LogLinearProgram) -> tuple[str, np.ndarray[Any, Any] | None]:
        rhs = np.array([row.rhs for row in lp.rows], dtype=float)
        if any(rhs[i] < 0 for i, row in enumerate(lp.rows) if not any(row.coefficients)):
            return cp.INFEASIBLE, None  # a row without variables that is never met
        # a row so loose that e^-rhs underflows can never bind: the smallest normal float
        with np.errstate(over="ignore", under="ignore"):
            scales = np.maximum(np.exp(-rhs), np.finfo(float).tiny)
            values = [
                (self.lo, np.exp(lp.lower)),
                (self.hi, np.exp(lp.upper)),
                *((r, scales[i]) for r, i in zip(self.r, self.rows, strict=True)),
                *((p, t.coefficient) for p, t in zip(self.p, lp.cost, strict=True)),
            ]
        arrays = [(parameter, np.asarray(value, dtype=float)) for parameter, value in values]
        if not all(np.all(np.isfinite(a)) and np.all(a > 0) for _, a in arrays):
            raise SolverError(
                f"operation {lp.operation!r}: a limit or cost coefficient is out of the "
                "floating-point range of the geometric program"
            )
        with self.lock:
            for parameter, array in arrays:
                parameter.value = array
            status = self._run(lp.operation, _CLARABEL)
            if status == cp.OPTIMAL_INACCURATE:  # too tight for this one: Clarabel's own
                status = self._run(lp.operation, {})
            if status != cp.OPTIMAL or self.x.value is None:
                return status, None
            return status, np.log(np.asarray(self.x.value, dtype=float))

    def _run(self, operation: str, options: Mapping[str, float]) -> str:
        try:
            with warnings.catch_warnings():
                warnings.filterwarnings("ignore", "Solution may be inaccurate", UserWarning)
                self.problem.solve(gp=True, solver=cp.CLARABEL, warm_start=False, **options)
        except cp.error.SolverError as err:
            raise SolverError(f"operation {operation!r}: solver failed ({err})") from err
        return str(self.problem.status)


def _structure(lp: LogLinearProgram) -> _Structure:
    terms = tuple(tuple(t.exponents.get(p, 0.0) for p in lp.parameters) for t in lp.cost)
    return (len(lp.parameters), tuple(r.coefficients for r in lp.rows), terms)


@lru_cache(maxsize=128)
def _program(structure: _Structure) -> _CostProgram:
    return _CostProgram(structure)


def dgp_problem(lp: LogLinearProgram) -> cp.Problem:
    """The cvxpy geometric program that minimises ``lp.cost`` under ``lp``'s rows and bounds."""
    _check_cost(lp)
    return _program(_structure(lp)).problem


def minimize(lp: LogLinearProgram) -> tuple[str, np.ndarray[Any, Any] | None]:
    """Solve the geometric program of ``lp``: status and, when optimal, the ln-parameters.

    Raises
    ------
    SolverError
        The solver failed, or a coefficient does not fit in floating point.
    """
    _check_cost(lp)
    return _program(_structure(lp)).solve(lp)


def _check_cost(lp: LogLinearProgram) -> None:
    unknown = {name for t in lp.cost for name in t.exponents} - set(lp.parameters)
    if not lp.cost or unknown:
        raise ValueError(f"operation {lp.operation!r}: cost terms {lp.cost} do not fit the program")
