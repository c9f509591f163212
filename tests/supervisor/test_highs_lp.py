"""The direct HiGHS solve of a log-linear program against cvxpy's solve of the same program.

:mod:`supervisor.optimize.highs_lp` hands the program to HiGHS without cvxpy (for speed); these
tests pose the same ``max c·x  s.t.  A x <= b,  lo <= x <= hi`` in cvxpy and require the same
answer: the same feasibility verdict and, where feasible, the same optimal objective value. The
elastic LP of the infeasibility diagnosis goes through the same solver, and nothing of it may reach
stdout (``rcb ... --json``).
"""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap
import warnings

import cvxpy as cp
import highspy
import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from supervisor.optimize import highs_lp, solve
from supervisor.optimize.program import LogLinearProgram, Row

from conftest import ROOT

PARAMS = ("depth_mm", "feed_mm_rev", "speed_m_min")
#: Clarabel's stopping tolerances for the reference solve.
REFERENCE_TOLERANCES = {"tol_feas": 1e-12, "tol_gap_abs": 1e-12, "tol_gap_rel": 1e-12}


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
    # the reference solved to 1e-12: at Clarabel's defaults (1e-8) a bound crossed by 3.5e-9
    # let a row of coefficient 0.004 reach 2.6e-6 past the optimum (HiGHS: 0, exact), over
    # the 1e-6 the objectives are compared to; where it cannot get there, at its defaults
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "Solution may be inaccurate"
        problem.solve(solver=cp.CLARABEL, **REFERENCE_TOLERANCES)
        if problem.status == cp.OPTIMAL_INACCURATE:
            problem.solve(solver=cp.CLARABEL)
    return str(problem.status), problem.value


def _assert_feasible(lp: LogLinearProgram, x: np.ndarray) -> None:
    """``x`` meets every row and bound of ``lp`` within HiGHS' primal tolerance (1e-7)."""
    a = np.array([r.coefficients for r in lp.rows]).reshape(-1, 3)
    assert np.all(a @ x <= np.array([r.rhs for r in lp.rows]) + 1e-7)
    assert np.all(x >= np.array(lp.lower) - 1e-7) and np.all(x <= np.array(lp.upper) + 1e-7)


exponent = st.floats(-2.0, 2.0, allow_nan=False).map(lambda v: round(v, 3))
row = st.tuples(st.tuples(exponent, exponent, exponent), st.floats(-3.0, 6.0))


@settings(max_examples=150, deadline=None)
@example(  # the reference at its default tolerances said 2.6e-6 (a full suite run, 2026-12-04)
    rows=[((0.0, 0.0, 0.0), 0.0), ((0.0, 2.0, 0.004), 0.0)],
    lower=(0.0, 0.0, 0.0),
    width=(0.0, 5.960464477539063e-08, 1.0),
    objective=(1.0, 0.0, 1.0),
)
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
    try:
        reference, value = _cvxpy(lp)
    except cp.error.SolverError:  # the reference cannot answer (Clarabel on a degenerate box)
        assume(False)
    if status == "optimal":  # whatever the reference says, HiGHS' optimum is a feasible point
        _assert_feasible(lp, x)
    if reference == cp.OPTIMAL:
        assert status == "optimal"
        assert_allclose(np.dot(lp.objective, x), value, atol=1e-6)
    elif reference == cp.INFEASIBLE:
        # Infeasible by less than the solvers' tolerances (a fixed parameter 1e-6 over a row's
        # bound): HiGHS may call it optimal, but only with a point inside its primal feasibility
        # tolerance (1e-7, checked above); a program infeasible by more must be called so.
        assert status in ("infeasible", "optimal")


def _fresh(lp: LogLinearProgram) -> tuple[str, bytes | None]:
    """``lp`` solved on a new HiGHS instance, the optimum's bytes (what a fresh solve gives)."""
    highs = highs_lp._new_highs()
    a = [r.coefficients for r in lp.rows]
    b = [r.rhs for r in lp.rows]
    sense = highspy.ObjSense.kMaximize
    highs.passModel(highs_lp._model(lp.objective, a, b, lp.lower, lp.upper, sense=sense))
    highs.run()
    status, x = highs_lp._result(highs)
    return status, None if x is None else x.tobytes()


#: A few coefficient matrices (1-5 rows), so that a sequence comes back to a kept instance.
matrices = st.lists(
    st.lists(st.tuples(exponent, exponent, exponent), min_size=1, max_size=5).map(tuple),
    min_size=1,
    max_size=3,
)


@st.composite
def sequences(draw: st.DrawFn) -> list[LogLinearProgram]:
    """Programs over a few matrices, each with its own costs, bounds and right-hand sides."""
    pool = draw(matrices)
    programs = []
    for _ in range(draw(st.integers(2, 16))):
        coefficients = draw(st.sampled_from(pool))
        rows = [(c, draw(st.floats(-3.0, 6.0))) for c in coefficients]
        lower = draw(st.tuples(*[st.floats(-3.0, 1.0)] * 3))
        width = draw(st.tuples(*[st.floats(0.0, 3.0)] * 3))
        upper = [lo + w for lo, w in zip(lower, width, strict=True)]
        objective = draw(st.tuples(*[st.sampled_from([0.0, 1.0])] * 3))
        programs.append(_program(rows, lower, upper, objective))
    return programs


@settings(max_examples=150, deadline=None)
@given(sequences())
def test_a_kept_instance_answers_bit_for_bit_as_a_fresh_one(programs):
    # The thread keeps a HiGHS instance per coefficient matrix and only updates costs, bounds
    # and right-hand sides: each answer must be the fresh instance's, to the last bit, whatever
    # was solved before it (ties between optimal vertices included).
    for lp in programs:
        status, x = highs_lp.maximize(lp)
        assert (status, None if x is None else x.tobytes()) == _fresh(lp)


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


# The elastic LP of two impossible rows and a loose one, bounds 0 <= x <= 1:
#   q0: x0 + 2 x1 <= -0.5    needs s0 = x0 + 2 x1 + 0.5
#   q1:     -  x1 <= -2      needs s1 = 2 - x1
#   q2:           x2 <= 5    met by every x
# sum(s) = x0 + x1 + 2.5 is least at x0 = x1 = 0: s = (0.5, 2, 0), total 2.5.
ELASTIC_ROWS = [((1.0, 2.0, 0.0), -0.5), ((0.0, -1.0, 0.0), -2.0), ((0.0, 0.0, 1.0), 5.0)]


def test_the_elastic_lp_of_a_hand_solved_infeasible_program():
    a = np.array([coefficients for coefficients, _ in ELASTIC_ROWS])
    status, xs = highs_lp.solve_lp(
        [0, 0, 0, 1, 1, 1],
        np.hstack([a, -np.eye(3)]),
        [rhs for _, rhs in ELASTIC_ROWS],
        [0.0] * 6,
        [1.0] * 3 + [highspy.kHighsInf] * 3,
        maximize=False,
    )
    assert status == "optimal"
    assert_allclose(xs[:2], [0.0, 0.0], atol=1e-12)
    assert_allclose(xs[3:], [0.5, 2.0, 0.0], atol=1e-12)
    # without the slacks the program is infeasible
    lp = _program(ELASTIC_ROWS, [0.0] * 3, [1.0] * 3, (1, 1, 1))
    assert highs_lp.maximize(lp) == ("infeasible", None)


def test_the_diagnosis_names_the_rows_with_slack_and_what_they_need():
    lp = _program(ELASTIC_ROWS, [0.0] * 3, [1.0] * 3, (1, 1, 1))
    error = solve.diagnose(lp)
    # q0 needs ln(limit) raised by its slack 0.5, q1 by 2; q2 is not in conflict
    assert [c.name for c in error.conflicts] == ["q0", "q1"]
    assert_allclose([c.required for c in error.conflicts], [math.exp(0.0), math.exp(0.0)])
    assert_allclose([c.limit for c in error.conflicts], [math.exp(-0.5), math.exp(-2.0)])
    # the closest point sits on x0 >= 1 and x1 >= 1 (ln-bounds 0)
    assert {"depth_mm >= 1", "feed_mm_rev >= 1"} <= set(error.against)


def test_solving_and_diagnosing_print_nothing_to_stdout():
    # HiGHS prints its banner once per process, from C, when a highspy.Highs is built: run a
    # fresh process and require its stdout to be only what the script prints.
    script = textwrap.dedent(
        """
        import math
        from supervisor.optimize import highs_lp
        from supervisor.errors import InfeasibleError
        from supervisor.optimize.program import LogLinearProgram, Row
        from supervisor.optimize.optimizer import optimize_plan
        from supervisor.inputs.plan import plan_from_mapping

        lp = LogLinearProgram(
            operation="op",
            parameters=("depth_mm", "feed_mm_rev", "speed_m_min"),
            objective=(1.0, 1.0, 1.0),
            rows=(Row("q0", (1.0, 1.0, 0.0), 0.5, math.exp(0.5), "max", "q0"),),
            lower=(0.0, 0.0, 0.0),
            upper=(1.0, 1.0, 1.0),
        )
        print("solve", highs_lp.maximize(lp)[0])
        plan = {
            "name": "p",
            "machine": {"name": "m", "max_power_kW": 22, "max_spindle_rpm": 4000},
            "operations": [
                {
                    "name": "rough-od",
                    "tool": "CNMG432RN",
                    "workpiece_diameter_mm": 60,
                    "volume_mm3": 86400,
                    "limits": {"force_N": 50},
                    "bounds": {
                        "depth_mm": [0.5, 3.0],
                        "feed_mm_rev": [0.1, 0.6],
                        "speed_m_min": [100, 200],
                    },
                }
            ],
        }
        try:
            optimize_plan(plan_from_mapping(plan))
        except InfeasibleError as error:
            print("diagnosed", [c.name for c in error.conflicts])
        """
    )
    proc = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, cwd=ROOT, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == "solve optimal\ndiagnosed ['force_N']\n"
