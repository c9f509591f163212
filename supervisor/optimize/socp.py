"""One operation's program with learned (cone) rows, solved by Clarabel directly.

The ``learn`` strategy's robust rows are second-order cones, ``a·x + z‖G x + h‖ <= b``
(:mod:`supervisor.rcb.posterior`), beside the linear rows and bounds of
:mod:`supervisor.optimize.formulation`. Clarabel (an interior-point conic solver, the one cvxpy uses
for such programs) takes them in its standard form ``min q·x  s.t.  A x + s = b, s ∈ K``:

- each linear row and bound: one row of the non-negative cone, ``s = b − a·x >= 0``;
- each cone row: ``s = ((b − m − a·x)/z, G x + h) ∈ SOC``, i.e. ``‖G x + h‖ <= (b − m − a·x)/z``
  with ``m`` = :data:`CONE_MARGIN`.

Why Clarabel directly and not HiGHS with outer-approximation cuts: measured on the demo plan's
learned programs (``benchmarks/solve_speed.py``, section 6), Kelley's cutting planes converge
linearly where the optimum lies on a curved cone face (1.5-2.2 ms median, up to 60 HiGHS runs)
while Clarabel solves the same 3-variable program in 0.3 ms, its solver kept per program
structure and thread and updated with the new data; cvxpy adds its own per-call work on top
(:mod:`supervisor.optimize.highs_lp` says how much).

The interior-point answer meets the rows to Clarabel's tolerance (about 1e-8); the margin
``m`` (1 ppm of the quantity) keeps the point inside the true cone, and the optimiser re-checks
it as every optimum.
"""

from __future__ import annotations

import functools
import threading
from typing import Any, Literal

import clarabel
import numpy as np

from supervisor.optimize.program import LogLinearProgram

Status = Literal["optimal", "infeasible", "failed"]

#: Cone rows are solved against ``b − CONE_MARGIN`` (in ln of the quantity: 1 ppm).
CONE_MARGIN = 1e-6

_SETTINGS: Any = None


def _settings() -> Any:
    global _SETTINGS
    if _SETTINGS is None:
        _SETTINGS = clarabel.DefaultSettings()
        _SETTINGS.verbose = False
        # data updates of a kept solver need presolve and chordal decomposition off; and
        # equilibration, whose scaling is made from the data a solver is built with, would
        # make an answer depend on which program built it (the results of `rcb certify` must
        # be the same for any --jobs); the programs are small and scaled (logarithms)
        _SETTINGS.presolve_enable = False
        _SETTINGS.chordal_decomposition_enable = False
        _SETTINGS.equilibrate_enable = False
    return _SETTINGS


@functools.cache
def _zeros(n: int) -> Any:
    """The (empty) quadratic term of an ``n``-variable linear objective, made once."""
    from scipy import sparse  # imported where used: see _solver

    return sparse.csc_matrix((n, n))


_local = threading.local()
#: Most program structures a thread keeps a solver for (a plan has a few).
MAX_SOLVERS = 64


def _solver(n: int, dense: Any, b: Any, cones: list[Any], q: Any) -> Any:
    """A Clarabel solver holding this program: the thread's one for its structure, updated.

    ``A`` goes in with every entry of ``dense`` stored, zeros included, so that programs of
    one structure (rows, cone sizes) share a sparsity pattern and a solver: the next one is
    a data update (``solver.update``), which skips building the solver and its symbolic
    factorisation (about a third of a solve here, ``benchmarks/solve_speed.py``).
    """
    solvers: dict[tuple[Any, ...], Any] = getattr(_local, "solvers", None) or {}
    _local.solvers = solvers
    rows = dense.shape[0]
    key = (n, rows, tuple(repr(c) for c in cones))
    values = dense.T.ravel()  # column-major: the CSC order of a full pattern
    solver = solvers.get(key)
    if solver is not None:
        solver.update(q=q, A=values, b=b)
        return solver
    # imported here: scipy takes 0.2-0.5 s to import, which every reader of a plan (rcb
    # plans, rcb history) paid at start through the optimizer's imports, never solving
    from scipy import sparse

    indices = np.tile(np.arange(rows, dtype=np.int32), n)
    indptr = np.arange(0, rows * n + 1, rows, dtype=np.int32)
    A = sparse.csc_matrix((values, indices, indptr), shape=dense.shape)
    solver = clarabel.DefaultSolver(_zeros(n), q, A, b, cones, _settings())
    if len(solvers) >= MAX_SOLVERS:
        solvers.clear()
    solvers[key] = solver
    return solver


def maximize(lp: LogLinearProgram) -> tuple[Status, Any]:
    """Solve ``max objective·x`` under ``lp``'s linear rows, cone rows and bounds.

    Returns ``("optimal", x)`` (ln-parameters in ``lp.parameters`` order),
    ``("infeasible", None)`` when Clarabel proves no point meets every row, and
    ``("failed", None)`` for any other outcome.
    """
    n = len(lp.parameters)
    linear = [r for r in lp.rows if r.cone is None]
    eye = np.eye(n)
    blocks = [np.array([r.coefficients for r in linear]).reshape(-1, n), eye, -eye]
    rhs = [
        np.array([r.rhs for r in linear], dtype=float),
        np.array(lp.upper, dtype=float),
        -np.array(lp.lower, dtype=float),
    ]
    cones: list[Any] = [clarabel.NonnegativeConeT(len(linear) + 2 * n)]
    for row in lp.rows:
        if row.cone is None:
            continue
        G, h, z = row.cone.G, row.cone.h, row.cone.z
        blocks += [np.array(row.coefficients)[None, :] / z, -G]
        rhs += [np.array([(row.rhs - CONE_MARGIN) / z]), h]
        cones.append(clarabel.SecondOrderConeT(1 + len(h)))
    dense = np.vstack(blocks)
    solver = _solver(n, dense, np.concatenate(rhs), cones, -np.array(lp.objective, dtype=float))
    solution = solver.solve()
    status = str(solution.status)
    if status == "Solved":
        return "optimal", np.array(solution.x, dtype=float)
    if status in ("PrimalInfeasible", "AlmostPrimalInfeasible"):
        return "infeasible", None
    return "failed", None


def meets(lp: LogLinearProgram, x: Any, slack_z: float = 0.0) -> bool:
    """Whether ``x`` meets every row of ``lp`` (cone rows against ``b − CONE_MARGIN``).

    ``slack_z``: cone rows are checked with ``z − slack_z`` instead of ``z``.
    """
    lower, upper = np.array(lp.lower), np.array(lp.upper)
    if np.any(x < lower - 1e-12) or np.any(x > upper + 1e-12):
        return False
    for row in lp.rows:
        value = float(np.dot(row.coefficients, x))
        if row.cone is None:
            if value > row.rhs + 1e-12:
                return False
            continue
        spread = float(np.linalg.norm(row.cone.G @ x + row.cone.h))
        if value + (row.cone.z - slack_z) * spread > row.rhs - CONE_MARGIN:
            return False
    return True
