"""The grid rule (:mod:`supervisor.optimize.grid`) on hand-made log-linear programs: the best grid
neighbour of the continuous optimum that meets every row, else the best neighbour of the
tightened program's optimum, never a point that breaks a row or a bound (Hypothesis too). Its
plans, the CLI and the REST service: test_setpoint_resolution.py.
"""

from __future__ import annotations

import math

import numpy as np
from grid_support import on_grid, steps
from hypothesis import assume, event, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from supervisor.inputs.resolution import DEFAULT_RESOLUTION, steps_within
from supervisor.optimize import grid, highs_lp
from supervisor.optimize.program import LogLinearProgram, Row


def test_float_noise_next_to_a_bound_is_the_bound():
    # the values: 3.0000000000000004 with bound 3.0, 10.000000000000002 on a 10 mm
    # tool (radial depth fixed), 199.99999999999991 with bound 200
    bounds = {"depth_mm": (0.5, 3.0), "radial_depth_mm": (10.0, 10.0), "speed_m_min": (100, 200)}
    values = (3.0000000000000004, 10.000000000000002, 199.99999999999991)
    points = grid.candidates(tuple(bounds), values, bounds, DEFAULT_RESOLUTION)
    assert points.tolist() == [[3.0, 10.0, 200.0]]


def _program(rows, lower, upper, objective=(1.0, 1.0, 1.0)) -> LogLinearProgram:
    return LogLinearProgram(
        operation="op",
        parameters=("depth_mm", "feed_mm_rev", "speed_m_min"),
        objective=tuple(objective),
        rows=tuple(
            Row(f"q{i}", c, b, math.exp(b), "max", f"q{i}") for i, (c, b) in enumerate(rows)
        ),
        lower=tuple(math.log(v) for v in lower),
        upper=tuple(math.log(v) for v in upper),
    )


def _solve_or_none(lp: LogLinearProgram) -> np.ndarray | None:
    status, x = highs_lp.maximize(lp)
    return np.clip(x, lp.lower, lp.upper) if status == "optimal" else None


def test_rounding_the_speed_down_would_break_roughness_so_the_rule_does_not():
    # Roughness f · v^-0.5 <= R (it falls with speed) binds with v on its bound 200.5, which
    # is no grid point: v must go down to 200, and with it the feed by sqrt(200/200.5) - 1
    # = -0.125 %, more than one feed step (0.0001 of about 0.3 mm/rev). So no grid
    # neighbour of the optimum meets the row (rounding everything down breaks it); fixing v
    # first (its one candidate) and re-solving gives the feed.
    bounds = {"depth_mm": (0.5, 3.0), "feed_mm_rev": (0.05, 0.6), "speed_m_min": (100, 200.5)}
    rhs = math.log(0.3) - 0.5 * math.log(200.5)
    lp = _program([((0.0, 1.0, -0.5), rhs)], *zip(*bounds.values(), strict=True))
    x = _solve_or_none(lp)
    assert x is not None
    assert_allclose(np.exp(x), [3.0, 0.3, 200.5])
    floor = np.array([3.0, 0.2999, 200.0])  # every parameter rounded down
    assert not grid.meets(lp, floor[None, :])[0]
    assert grid.on_grid(lp, x, bounds, DEFAULT_RESOLUTION) is None
    found = grid.machine_point(lp, x, bounds, DEFAULT_RESOLUTION, _solve_or_none)
    assert found is not None
    # f <= 0.3 · sqrt(200 / 200.5) = 0.299626: the best grid feed at v = 200 is 0.2996
    assert found[2].tolist() == [3.0, 0.2996, 200.0]
    assert grid.meets(lp, found[2][None, :])[0]
    # the last resort alone (tightened rows) is safe too, at one step of v at its low bound
    tight = grid.tightened(lp, bounds, DEFAULT_RESOLUTION)
    x_tight = _solve_or_none(tight)
    point = grid.on_grid(lp, x_tight, bounds, DEFAULT_RESOLUTION)
    assert point is not None and grid.meets(lp, point[None, :])[0]
    assert point[1] < 0.2996


exponent = st.floats(-2.0, 2.0, allow_nan=False).map(lambda v: round(v, 3))


@settings(max_examples=200, deadline=None)
@given(
    rows=st.lists(st.tuples(st.tuples(exponent, exponent, exponent), st.floats(0.0, 0.5))),
    lower=st.tuples(st.floats(0.05, 3.0), st.floats(0.01, 0.5), st.floats(20.0, 300.0)),
    ratio=st.tuples(*[st.floats(1.0, 5.0)] * 3),
    where=st.tuples(*[st.floats(0.0, 1.0)] * 3),
    objective=st.tuples(*[st.sampled_from([0.0, 0.5, 1.0])] * 3),
    resolution=steps,
)
def test_the_rule_never_returns_a_point_that_breaks_a_row_or_a_bound(
    rows, lower, ratio, where, objective, resolution
):
    # rows through a point inside the bounds, 0-0.5 above it in ln: feasible, and they bind
    upper = tuple(lo * r for lo, r in zip(lower, ratio, strict=True))
    inside = [math.log(lo) + t * math.log(r) for lo, r, t in zip(lower, ratio, where, strict=True)]
    rows = [(a, float(np.dot(a, inside)) + m) for a, m in rows]
    for p, lo, hi in zip(("depth_mm", "feed_mm_rev", "speed_m_min"), lower, upper, strict=True):
        k_low, k_high = steps_within(lo, hi, resolution[p])
        assume(k_low <= k_high)  # a plan refuses bounds that hold no grid point
    pairs = zip(lower, upper, strict=True)
    bounds = dict(zip(("depth_mm", "feed_mm_rev", "speed_m_min"), pairs, strict=True))
    lp = _program(rows, lower, upper, objective)
    x = _solve_or_none(lp)
    if x is None:
        return
    found = grid.machine_point(lp, x, bounds, resolution, _solve_or_none)
    if found is None:
        event("no grid point proven safe")
        assert _solve_or_none(grid.tightened(lp, bounds, resolution)) is None
        return
    held, _, point = found
    if held is not lp:
        event("tightened program")
    elif grid.on_grid(lp, x, bounds, resolution) is None:
        event("fix and re-solve")
    else:
        event("a grid neighbour")
    for (p, (low, high)), v in zip(bounds.items(), point, strict=True):
        assert low <= v <= high
        assert on_grid(float(v), resolution[p])
    ln = np.log(point)
    for coefficients, rhs in rows:
        assert float(np.dot(coefficients, ln)) <= rhs + 1e-12


@settings(max_examples=150, deadline=None)
@given(
    rows=st.lists(
        st.tuples(st.tuples(exponent, exponent, exponent), st.floats(0.0, 0.5)), min_size=1
    ),
    lower=st.tuples(st.floats(0.05, 3.0), st.floats(0.01, 0.5), st.floats(20.0, 300.0)),
    ratio=st.tuples(*[st.floats(1.0, 5.0)] * 3),
    where=st.tuples(*[st.floats(0.0, 1.0)] * 3),
    objective=st.tuples(*[st.floats(0.1, 1.0)] * 3),
    resolution=steps,
)
def test_every_grid_neighbour_of_the_tightened_optimum_meets_every_row(
    rows, lower, ratio, where, objective, resolution
):
    # the last resort's guarantee, by construction: rows tightened by one step of every
    # parameter at its low bound (ln(1 + step/low)) leave room for any rounding. The rows
    # pass a point inside the bounds with a margin of 0-0.5 in ln, so that they bind.
    upper = tuple(lo * r for lo, r in zip(lower, ratio, strict=True))
    params = ("depth_mm", "feed_mm_rev", "speed_m_min")
    for p, lo, hi in zip(params, lower, upper, strict=True):
        k_low, k_high = steps_within(lo, hi, resolution[p])
        assume(k_low <= k_high)
    bounds = dict(zip(params, zip(lower, upper, strict=True), strict=True))
    inside = [math.log(lo) + t * math.log(r) for lo, r, t in zip(lower, ratio, where, strict=True)]
    through = [(a, float(np.dot(a, inside)) + m) for a, m in rows]
    lp = _program(through, lower, upper, objective)
    x = _solve_or_none(grid.tightened(lp, bounds, resolution))
    if x is None:
        event("the tightened program is infeasible")
        return
    points = grid.candidates(params, np.exp(x), bounds, resolution)
    event(f"{len(points)} neighbours")
    assert grid.meets(lp, points).all()


def test_limits_met_exactly_at_a_corner_of_bounds_off_the_grid_find_a_grid_point():
    """Found by Hypothesis (tests/supervisor/test_properties.py): force and tool life both
    met exactly at the corner of depth's lower bound, feed's upper and speed's lower (off the
    1e-9 grid). The tightened program's optimum passed its tool-life row by 2e-7, within
    HiGHS's tolerance, so no grid point next to it met the rows and the plan was called
    infeasible, with conflicts that asked for the limits it had (127.303 needing 127.3). A
    grid point exists (depth one step up, feed three down): step 5 tightens again and finds
    one."""
    from models.powerlaw import PowerLawModel
    from supervisor.inputs.plan import plan_from_mapping
    from supervisor.optimize.optimizer import optimize_plan

    force = {"K": 148.4131591025766, "dK": 0.0, "exponents": {"depth_mm": 1.0, "feed_mm_rev": 0.5}}
    life = {
        "K": 14650719.428953517,
        "dK": 0.0,
        "exponents": {"depth_mm": 0.5, "speed_m_min": -3.0, "flank_wear_mm": 1.0},
    }
    limits = {"force_N": 127.30344793111759, "parts_per_edge": 0.00122603143153922}
    bounds = {
        "depth_mm": [1.0, 2.0],
        "speed_m_min": [148.4131591025766, 296.8263182051532],
        "feed_mm_rev": [0.36787944117144233, 0.7357588823428847],
    }
    data = {
        "name": "corner",
        "machine": {"name": "m", "resolution": dict.fromkeys(bounds, 1e-9)},
        "tools": [
            {"name": "T", "process": "turning", "models": {"force_N": force, "tool_life_mm3": life}}
        ],
        "operations": [
            {
                "name": "op-1",
                "tool": "T",
                "workpiece_diameter_mm": 20.085536923187668,
                "volume_mm3": 1096.6331584284585,
                "limits": limits,
                "bounds": bounds,
            }
        ],
    }
    (result,) = optimize_plan(plan_from_mapping(data)).operations
    point = dict(result.setpoint)
    assert point["depth_mm"] > 1.0 and point["feed_mm_rev"] < bounds["feed_mm_rev"][1]
    for name, value in point.items():  # on the grid
        assert abs(value / 1e-9 - round(value / 1e-9)) < 1e-3, name
    assert PowerLawModel("force_N", **force).predict(point, {}).upper <= limits["force_N"]
    assert result.predicted["tool_life_mm3"].lower >= limits["parts_per_edge"] * 1096.6331584284585
