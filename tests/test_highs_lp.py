"""The direct HiGHS solve of a log-linear program against cvxpy's solve of the same program.

:mod:`supervisor.highs_lp` hands the program to HiGHS without cvxpy (for speed); these tests
pose the same ``max c·x  s.t.  A x <= b,  lo <= x <= hi`` in cvxpy and require the same
answer: the same feasibility verdict and, where feasible, the same optimal objective value.
"""

from __future__ import annotations

import math

import cvxpy as cp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from supervisor import highs_lp
from supervisor.formulation import LogLinearProgram, Row

PARAMS = ("depth_mm", "feed_mm_rev", "speed_m_min")


def _program(rows: list[tuple[tuple[float, ...], float]], lower, upper, objective):
    return LogLinearProgram(
        operation="op",
        parameters=PARAMS,
        objective=tuple(objective),
        rows=tuple(
            Row(f"q{i}", coeffs, rhs, math.exp(rhs), "max", f"q{i}")
            for i, (coeffs, rhs) in enumerate(rows)
        ),
        lower=tuple(lower),
        upper=tuple(upper),
    )


def _cvxpy(lp: LogLinearProgram) -> tuple[str, float | None]:
    x = cp.Variable(len(lp.parameters))
    constraints = [x >= np.array(lp.lower), x <= np.array(lp.upper)]
    if lp.rows:
        a = np.array([r.coefficients for r in lp.rows])
        constraints.append(a @ x <= np.array([r.rhs for r in lp.rows]))
    problem = cp.Problem(cp.Maximize(np.array(lp.objective) @ x), constraints)
    problem.solve(solver=cp.CLARABEL)
    return str(problem.status), problem.value


exponent = st.floats(-2.0, 2.0, allow_nan=False).map(lambda v: round(v, 3))
row = st.tuples(st.tuples(exponent, exponent, exponent), st.floats(-3.0, 6.0))


@settings(max_examples=150, deadline=None)
@given(
    rows=st.lists(row, max_size=8),
    lower=st.tuples(*[st.floats(-3.0, 1.0)] * 3),
    width=st.tuples(*[st.floats(0.0, 3.0)] * 3),
    objective=st.tuples(*[st.sampled_from([0.0, 1.0])] * 3),
)
def test_highs_agrees_with_cvxpy(rows, lower, width, objective):
    upper = [lo + w for lo, w in zip(lower, width, strict=True)]
    lp = _program(rows, lower, upper, objective)
    status, x = highs_lp.maximize(lp)
    reference, value = _cvxpy(lp)
    if reference == cp.OPTIMAL:
        assert status == "optimal"
        assert_allclose(np.dot(lp.objective, x), value, atol=1e-6)
        a = np.array([r.coefficients for r in lp.rows]).reshape(-1, 3)
        assert np.all(a @ x <= np.array([r.rhs for r in lp.rows]) + 1e-7)
        assert np.all(x >= np.array(lower) - 1e-7) and np.all(x <= np.array(upper) + 1e-7)
    elif reference == cp.INFEASIBLE:
        assert status == "infeasible"


def test_a_hand_solved_program():
    # max ln d + ln f + ln v with d <= 3, f <= 0.6, v <= 200 and one force row
    # 0.888 ln d + 0.783 ln f <= ln(2000 / 2280). Per unit of the row, ln f gains 1/0.783 and
    # ln d only 1/0.888, so f goes to its bound and d takes what the row leaves.
    rhs = math.log(2000 / 2280)
    lp = _program(
        [((0.888, 0.783, 0.0), rhs)],
        [math.log(0.5), math.log(0.05), math.log(100)],
        [math.log(3.0), math.log(0.6), math.log(200)],
        (1.0, 1.0, 1.0),
    )
    status, x = highs_lp.maximize(lp)
    assert status == "optimal"
    d = math.exp((rhs - 0.783 * math.log(0.6)) / 0.888)
    assert_allclose(np.exp(x), [d, 0.6, 200.0], rtol=1e-9)
    assert d == pytest.approx(1.354, abs=1e-3)


def test_an_impossible_program_is_infeasible_with_and_without_presolve():
    lp = _program([((1.0, 0.0, 0.0), math.log(0.1))], [math.log(0.5)] * 3, [0.0] * 3, (1, 1, 1))
    assert highs_lp.maximize(lp) == ("infeasible", None)
    assert highs_lp.maximize(lp, presolve=True) == ("infeasible", None)


@pytest.mark.parametrize("rows", [[], [((0.0, 0.0, 0.0), 1.0)]])
def test_only_bounds(rows):
    lp = _program(rows, [-1.0, -2.0, -3.0], [1.0, 2.0, 3.0], (1.0, 0.0, 1.0))
    status, x = highs_lp.maximize(lp)
    assert status == "optimal"
    assert x[0] == pytest.approx(1.0) and x[2] == pytest.approx(3.0)
