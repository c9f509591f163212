"""The rise per part of a wearing edge (supervisor.rcb.wear) and the law's projected margin.

Hand numbers follow the module docstring of supervisor.rcb.wear; the plan is the demo plan,
whose rough-od has ``parts_per_edge = 10`` (n_max = 9) and a 2000 N force limit.
"""

from __future__ import annotations

import math
import tomllib

import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan
from supervisor.inputs.part_report import Measurement, PartReport
from supervisor.inputs.plan import load_plan
from supervisor.rcb import wear
from supervisor.rcb.replan import replan
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start, update
from supervisor.virtual.scenario import run_scenario

from conftest import DEMO_PLAN, cached_state, stored_state

SETPOINT = {"depth_mm": 2.0, "feed_mm_rev": 0.3, "speed_m_min": 200.0}
EXPONENTS = {"depth_mm": 0.888, "feed_mm_rev": 0.783, "speed_m_min": -0.0395}
PLAN_BODY = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
PRIOR = wear.prior(9, 0.1)  # s_w = 0.1 over an edge's life, n_max = 9


def _observe(belief, age, y, u=2.0, point=SETPOINT):
    return wear.observe(belief, age, Measurement(y, u), point, EXPONENTS, 2.0, 0.15)


def test_prior_and_its_projection_by_hand():
    # P0 = (0.1 / 9)² = 1.2346e-4; before any difference the rise is 0 + 2·0.1/9 per part,
    # so a reading of a new edge is projected by exp(0.2) over its 9 parts to come
    assert PRIOR.mean == 0.0
    assert_allclose(PRIOR.var, 1.2345679e-4, rtol=1e-7)
    assert_allclose(PRIOR.factor(0, 2.0), math.exp(0.2))
    assert PRIOR.factor(9, 2.0) == 1.0  # the edge's last part: nothing to come
    assert PRIOR.factor(12, 2.0) == 1.0  # past n_max (an edge run longer): nothing either
    assert PRIOR.factor(None, 2.0) == 1.0  # unknown age: not projected


def test_two_readings_of_one_edge_by_hand():
    # 1000 ± 2 N at age 0, 1005 ± 2 N at age 1, same setpoint: s = 1e-3 and 1/1005,
    # d = ln 1.005 = 4.98754e-3, Var η = 1e-6 + 9.90074e-7 = 1.990075e-6,
    # g = P0 / (P0 + Var η) = 0.984136, ŵ = g d = 4.90842e-3, P = (1 − g) P0 = 1.958504e-6,
    # upper = ŵ + 2 √P = 7.70735e-3, projection at age 1: exp(8 · upper) = 1.063599
    first = _observe(PRIOR, 0, 1000.0)
    assert first.mean == 0.0 and first.var == PRIOR.var and first.differences == 0
    second = _observe(first, 1, 1005.0)
    assert_allclose(second.mean, 4.908420e-3, rtol=1e-6)
    assert_allclose(second.var, 1.958504e-6, rtol=1e-6)
    assert_allclose(second.upper(2.0), 7.707351e-3, rtol=1e-6)
    assert_allclose(second.factor(1, 2.0), 1.063599, rtol=1e-6)
    assert second.differences == 1 and second.last.age == 1


def test_a_change_of_setpoint_is_taken_out_and_counts_as_noise():
    # an exact power law with no wear, read at two setpoints: d = 0, the rise stays 0, and
    # the exponents' prior spread (15 %) of the setpoint change widens the noise
    moved = {**SETPOINT, "feed_mm_rev": 0.33}
    y0 = 2000.0 * math.prod(SETPOINT[n] ** e for n, e in EXPONENTS.items())
    y1 = 2000.0 * math.prod(moved[n] ** e for n, e in EXPONENTS.items())
    same = _observe(_observe(PRIOR, 0, y0), 1, y0)
    apart = _observe(_observe(PRIOR, 0, y0), 1, y1, point=moved)
    assert_allclose(apart.mean, 0.0, atol=1e-15)
    misfit = (0.15 * 0.783 * math.log(1.1)) ** 2
    eta = (1 / y0) ** 2 + (1 / y1) ** 2 + misfit
    assert_allclose(apart.var, PRIOR.var * eta / (PRIOR.var + eta), rtol=1e-9)
    assert apart.var > same.var


def test_a_new_edge_or_an_unknown_age_breaks_the_chain():
    worn = _observe(_observe(PRIOR, 0, 1000.0), 1, 1005.0)
    new_edge = _observe(worn, 0, 990.0)  # age back to 0: a new edge, no difference
    assert (new_edge.mean, new_edge.var) == (worn.mean, worn.var) and new_edge.last.age == 0
    unknown = _observe(worn, None, 1010.0)
    assert (unknown.mean, unknown.var, unknown.last) == (worn.mean, worn.var, None)
    after_unknown = _observe(unknown, 2, 1010.0)  # no difference across the unknown age
    assert after_unknown.differences == worn.differences


@given(st.floats(0.0, 0.01), st.lists(st.floats(-1.0, 1.0), min_size=9, max_size=9))
def test_the_belief_converges_and_stays_conservative(rise, noise):
    # readings of one edge at one setpoint rising by exp(rise) per part, noise within ±u/2:
    # the bound the projection uses is never below the truth by more than the noise allows,
    # and the variance shrinks with every difference
    belief = PRIOR
    variances = []
    for age in range(10):
        y = 1000.0 * math.exp(rise * age) + (noise[age - 1] if age else 0.0)
        belief = _observe(belief, age, y)
        variances.append(belief.var)
    assert belief.differences == 9
    assert all(b < a for a, b in zip(variances[1:], variances[2:], strict=False))
    assert belief.upper(2.0) >= rise - 4e-3  # 1 N of noise on 1000 N: 1e-3 per reading


@given(
    st.floats(-0.01, 0.01),
    st.floats(1e-12, 1e-3),
    st.integers(1, 50),
    st.integers(0, 1000),
    st.one_of(st.none(), st.integers(0, 50)),
)
def test_json_round_trip(mean, var, edge_max, differences, age):
    last = None if age is None else wear.Reading(age, 7.5, 1e-3, {"depth_mm": 0.69})
    belief = wear.WearRise(mean, var, edge_max, differences, last)
    assert wear.from_json(belief.to_json()) == belief


# --------------------------------------------------------------------------- the law


@pytest.fixture(scope="module")
def state():
    return start(load_plan(DEMO_PLAN), RcbSettings(strategy="ivester"))


def _force(state, serial, y, u, age):
    report = PartReport(
        serial,
        state.version,
        {"rough-od": {"force_N": Measurement(y, u)}},
        edge_parts={} if age is None else {"rough-od": age},
    )
    return update(state, report)


def test_a_new_edges_reading_is_projected_before_the_margin_law(state):
    # rough-od robust start: 1867.97 ± 131.55 N, limit 2000 N. 1800 ± 2 N by a new edge:
    # the paper's margin is 2000 − 1802 = 198 N, but projected by exp(0.2) (the prior) to the
    # edge's last part 1800 · 1.2214 + 2 = 2200.5 N: no margin, the band holds, unflagged
    before = state.setpoints.operations[0].predicted["force_N"]
    first, (d,) = _force(state, "W-1", 1800.0, 2.0, 0)
    assert d.action == "hold" and not d.flagged and d.note is None
    assert_allclose(d.margin, 2000 - (1800 * math.exp(0.2) + 2))
    assert d.band_after == d.band_before == pytest.approx(before.band)
    assert "edge's last part" in d.reason and "+22.1 %" in d.reason
    assert first.wear[("rough-od", "force_N")].last.age == 0
    # the same reading without the edge's age: the paper's law as it stands
    _, (plain,) = _force(state, "W-1", 1800.0, 2.0, None)
    assert plain.action == "shrink"
    assert_allclose(plain.margin, 198.0)
    assert_allclose(plain.band_after, before.band - 0.25 * 198.0)
    # the second part of the edge, same setpoint, 1809 ± 2 N: d = ln(1809/1800), s = 1/1800
    # and 1/1809; the rise learned and its bound projected over 8 parts (module docstring)
    second, (d2,) = _force(first, "W-2", 1809.0, 2.0, 1)
    p0 = (0.1 / 9) ** 2
    eta = (1 / 1800) ** 2 + (1 / 1809) ** 2
    g = p0 / (p0 + eta)
    upper = g * math.log(1809 / 1800) + 2 * math.sqrt((1 - g) * p0)
    margin = 2000 - (1809 * math.exp(8 * upper) + 2)
    assert 90 < margin < 95  # 92.1 N: the edge's wear, not the paper's 189 N
    assert d2.action == "shrink" and not d2.flagged
    assert_allclose(d2.margin, margin, rtol=1e-9)
    assert_allclose(d2.band_after, before.band - 0.25 * margin, rtol=1e-9)
    assert second.version == first.version + 1


def test_the_last_part_of_an_edge_and_flags_use_the_reading_itself(state):
    # at n_max nothing is projected; a reading under the band is never flagged for what the
    # projection says; one above the band's edge is, as before
    _, (last,) = _force(state, "W-9", 1800.0, 2.0, 9)
    assert_allclose(last.margin, 198.0)
    _, (high,) = _force(state, "W-0", 1999.0, 2.0, 0)  # 2001 N past the 1999.5 N edge
    assert high.flag == "above_band" and high.action == "expand"


def test_a_replan_that_resets_the_bands_forgets_the_rise(state):
    worn, _ = _force(state, "W-1", 1800.0, 2.0, 0)
    assert worn.wear
    other = {"limits": {"rough-grooves.force_N": 990}}  # a replan that keeps the bands
    assert replan(worn, PLAN_BODY, other).state.wear == worn.wear
    assert replan(worn, PLAN_BODY, {"reset_bands": True}).state.wear == {}


# --------------------------------------------------------------------------- the database


def test_the_rise_survives_a_reload(engine):
    created = create_plan(engine=engine, body=PLAN_BODY, settings=RcbSettings("ivester")).body
    plan_id, setpoints = created["id"], created
    for age, force in enumerate((1800.0, 1809.0, 1818.0)):
        body = {
            "serial": f"R-{age}",
            "setpoint_version": setpoints["setpoint_version"],
            "operations": [
                {
                    "name": "rough-od",
                    "edge_parts": age,
                    "measurements": {"force_N": {"value": force, "uncertainty": 2.0}},
                }
            ],
        }
        setpoints = report_part(engine=engine, plan_id=plan_id, report=parse_report(body)).body
    in_memory = cached_state(engine, plan_id)
    rise = in_memory.wear[("rough-od", "force_N")]
    assert rise.differences == 2 and rise.last.age == 2 and rise.mean > 0
    assert stored_state(engine, plan_id).wear == in_memory.wear


# --------------------------------------------------------------------------- closed loop

#: The seeds of the 1000 x 30 benchmark (wear drift 0.05) whose rough-od force crossed the
#: limit at the first edge's parts 9-10 under the paper's law before the projection (13
#: violations in 12 scenarios, 2026-11-25).
CROSSED = (150, 293, 304, 421, 481, 541, 549, 551, 561, 854, 947, 982)


def test_the_paper_law_on_a_wearing_edge_stays_under_the_limit():
    plan = load_plan(DEMO_PLAN)
    projected = start(plan, RcbSettings(strategy="ivester"))
    unprojected = start(plan, RcbSettings(strategy="ivester", edge_sd=0.0))  # rise fixed at 0
    crossed = 0
    for seed in CROSSED:
        trace = run_scenario(projected, seed, 11, wear_drift_per_edge_life=0.05)
        assert trace.violations.sum() == 0, (seed, trace.where)
        assert trace.plan_ratio[10] > 0.9  # the projection costs little: MRR/oracle after 10
        crossed += run_scenario(
            unprojected, seed, 11, wear_drift_per_edge_life=0.05
        ).violations.sum()
    # the same law without the projection still crosses: issue 27's measured noise scale
    # (supervisor.rcb.monitor: the rise inflates successive differences, so u grows) stops most
    # of the crossings it made before (12 seeds, 2 violations left; 1 since a grown band covers
    # its reading up to Q u, 2026-12-06), not all: the projection is still what holds them
    assert crossed >= 1
