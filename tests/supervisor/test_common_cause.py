"""A change every operation of a part shows at once (supervisor/rcb/common_cause.py, issue 27).

Hand-computed numbers: Stouffer's Z, DerSimonian and Laird's tau^2 and the leave-one-out shift;
then the rule through ``update`` on the demonstration plan: readings 2.5 sigma over what
``learn`` expects in every operation (each under its own alarm) are a change of every
operation, and an operation whose reading was quarantined moves by the others' shift.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from supervisor.inputs.part_report import Measurement, PartReport
from supervisor.inputs.plan import load_plan
from supervisor.rcb import common_cause as cc
from supervisor.rcb import learning
from supervisor.rcb.monitor_state import Monitor
from supervisor.rcb.noise_check import chains_of
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start, update
from supervisor.virtual.sampling import sample_machine
from supervisor.virtual.simulate import run_part

from conftest import DEMO_PLAN


def test_three_readings_near_three_sigma_are_a_common_change():
    # r = 0.10/0.04 = 2.5, 0.12/0.04 = 3, 0.09/0.05 = 1.8: Z = 7.3/sqrt(3) = 4.2147 > 4
    innovations = [(0.10, 0.0016), (0.12, 0.0016), (0.09, 0.0025)]
    assert cc.pooled_sigma(innovations) == pytest.approx(4.2146570, rel=1e-7)
    found = cc.common_shifts([("roughness_um", i) for i in innovations])
    assert set(found) == {"roughness_um"}
    # w = 625, 625, 400; mean 173.5/1650 = 0.1051515; Q = 0.2462 < m - 1 = 2: tau^2 = 0
    assert found["roughness_um"].tau2 == 0.0
    shift, variance = found["roughness_um"].shift()
    assert shift == pytest.approx(173.5 / 1650)
    assert variance == pytest.approx(1 / 1650)
    # without the first reading: (625 x 0.12 + 400 x 0.09) / 1025 = 0.1082927, variance 1/1025
    assert found["roughness_um"].shift(without=0) == pytest.approx((111 / 1025, 1 / 1025))


def test_operations_that_moved_apart_share_a_between_variance():
    # e = 0.30, 0.02, 0.10 at v = 0.0016: w = 625, mean 0.14, Q = 625 x 0.0416 = 26,
    # scale = 1875 - 3 x 625^2 / 1875 = 1250, tau^2 = (26 - 2)/1250 = 0.0192
    innovations = [(0.30, 0.0016), (0.02, 0.0016), (0.10, 0.0016)]
    assert cc.between_variance(innovations) == pytest.approx(0.0192)
    (found,) = cc.common_shifts([("force_N", i) for i in innovations]).values()
    # without the first: the mean of 0.02 and 0.10; variance (0.0016 + 0.0192)/2 + 0.0192
    assert found.shift(without=0) == pytest.approx((0.06, 0.0296))


def test_no_common_change_under_the_level_or_from_one_reading():
    assert cc.common_shifts([("force_N", (0.08, 0.0016))] * 3) == {}  # Z = 2 sqrt(3) = 3.46
    assert cc.common_shifts([("force_N", (0.40, 0.0016))]) == {}  # one reading: its own alarm
    mixed = [("force_N", (0.12, 0.0016)), ("roughness_um", (0.12, 0.0016))]
    assert cc.common_shifts(mixed) == {}  # 3 sigma each, but of two quantities


@given(st.lists(st.floats(-3, 3), min_size=2, max_size=8))
def test_stouffer_z_is_the_mean_r_times_root_m(rs):
    innovations = [(r * 0.05, 0.0025) for r in rs]
    assert cc.pooled_sigma(innovations) == pytest.approx(sum(rs) / math.sqrt(len(rs)), abs=1e-9)
    assert cc.between_variance(innovations) >= 0.0


def _learned_state(strategy="learn"):
    """``strategy`` after five clean parts of the demonstration plan (seed 3)."""
    plan = load_plan(DEMO_PLAN)
    machine = sample_machine(plan, seed=3)
    rng = np.random.default_rng(3)
    state = start(plan, RcbSettings(strategy=strategy))
    for k in range(5):
        setpoints = {op.name: op.setpoint for op in state.setpoints.operations}
        outcome = run_part(machine, setpoints, rng)
        state, _ = update(state, PartReport(f"P-{k}", state.version, outcome.measurements))
    return state


def _reading_at(state, operation, sigma, u=0.05):
    """A roughness reading ``sigma`` innovation-σ over what the strategy expects (high side)."""
    op = next(o for o in state.plan.operations if o.name == operation)
    made = next(r for r in state.setpoints.operations if r.name == operation)
    monitor = state.monitors.get((operation, "roughness_um")) or Monitor()
    _, expected = state.settings.rule.expects(state, op, made, "roughness_um", None, monitor)
    scale = monitor.scale
    y = math.exp(expected.mean)
    for _ in range(20):  # the reading's own noise (u/2)/y depends on y
        noise2 = (expected.noise**2 + ((u / 2) / y) ** 2) * scale**2
        v = expected.sd**2 + noise2
        y = math.exp(expected.mean + sigma * math.sqrt(v))
    return Measurement(y, u), expected.mean, v


def test_a_rise_every_operation_shows_is_a_change_of_each_and_of_the_one_unread():
    state = _learned_state()
    names = [op.name for op in state.plan.operations]
    unread, rest = names[0], names[1:]
    readings = {name: _reading_at(state, name, 2.5) for name in rest}
    measurements = {name: {"roughness_um": m} for name, (m, _, _) in readings.items()}
    measurements[unread] = {"roughness_um": Measurement(0.2, 0.05)}  # a dropout: quarantined
    new, decisions = update(state, PartReport("S-1", state.version, measurements))
    by_op = {d.operation: d for d in decisions}
    assert by_op[unread].note == "implausible_low"
    for name in rest:  # 2.5 sigma each, under CHANGE_SIGMA and the CUSUM; pooled sqrt(5) x 2.5
        assert by_op[name].note == "regime_change", name
        assert "pooled" in by_op[name].reason
    # the unread operation's intercept moved by the others' weighted shift (tau^2 = 0 here:
    # every r is 2.5, Q = sum w (e - mean)^2 is small), its variance by 1/sum(w)
    w = [1 / v for _, _, v in readings.values()]
    e = [2.5 * math.sqrt(v) for _, _, v in readings.values()]
    shift = float(np.dot(w, e) / sum(w))
    before = learning.belief_of(
        state, next(o for o in state.plan.operations if o.name == unread), "roughness_um"
    )
    after = new.posterior[(unread, "roughness_um")]
    assert after.mean[0] - before.mean[0] == pytest.approx(shift, rel=1e-9)
    assert after.cov[0][0] - before.cov[0][0] == pytest.approx(1 / sum(w), rel=1e-6)
    # and every operation backs off: the next setpoints remove less material
    old = {r.name: r.mrr_cm3_min for r in state.setpoints.operations}
    for r in new.setpoints.operations:
        assert r.mrr_cm3_min <= old[r.name] * (1 + 1e-9), r.name
    assert new.setpoints.cycle_time_min > state.setpoints.cycle_time_min


def test_a_rise_under_the_pooled_level_changes_nothing():
    state = _learned_state()
    names = [op.name for op in state.plan.operations]
    # 1.3 sigma in each of six: Z = 1.3 sqrt(6) = 3.18 < COMMON_SIGMA = 3.5
    measurements = {name: {"roughness_um": _reading_at(state, name, 1.3)[0]} for name in names}
    _, decisions = update(state, PartReport("S-1", state.version, measurements))
    assert all(d.note != "regime_change" for d in decisions)


def test_a_rise_over_the_pooled_level_under_the_one_reading_alarm_is_a_change():
    # 1.5 sigma in each of six: Z = 1.5 sqrt(6) = 3.67 > 3.5, each reading under the 4 sigma
    # of its own alarm (a step that one reading hides: all five faults, seed 987, Z = 3.97)
    state = _learned_state()
    names = [op.name for op in state.plan.operations]
    measurements = {name: {"roughness_um": _reading_at(state, name, 1.5)[0]} for name in names}
    _, decisions = update(state, PartReport("S-1", state.version, measurements))
    assert {d.note for d in decisions if d.quantity == "roughness_um"} == {"regime_change"}


def test_under_the_paper_law_the_unread_operation_band_covers_the_others_shift():
    # ivester learns no K: the quarantined operation's band grows to cover the higher of what
    # it expected (its last reading moved to the setpoint) and its band's edge, each raised
    # by the others' shift, at k = 2 of that value's spread (the expectation's, its last
    # reading's noise at the chain's prudent scale before the report, and the shift's; the
    # edge's: the shift's alone); past the limit, as a flagged reading of a change does, it
    # reaches (g / limit)^(k s) higher (the back-off's exponent error, law.py)
    state = _learned_state("ivester")
    names = [op.name for op in state.plan.operations]
    unread, rest = names[0], names[1:]
    readings = {name: _reading_at(state, name, 2.5) for name in rest}
    measurements = {name: {"roughness_um": m} for name, (m, _, _) in readings.items()}
    measurements[unread] = {"roughness_um": Measurement(0.2, 0.05)}
    new, decisions = update(state, PartReport("S-1", state.version, measurements))
    assert {d.note for d in decisions if d.operation in rest} == {"regime_change"}
    found = cc.common_shifts(
        ("roughness_um", (2.5 * math.sqrt(v), v)) for _, _, v in readings.values()
    )["roughness_um"]
    shift, variance = found.shift()
    op = next(o for o in state.plan.operations if o.name == unread)
    made = next(r for r in state.setpoints.operations if r.name == unread)
    monitor = state.monitors[(unread, "roughness_um")]
    _, high = state.settings.rule.expects(state, op, made, "roughness_um", None, monitor)
    value = math.exp(high.mean + shift)
    prudent = chains_of(state.monitors)["roughness_um"].prudent_scale
    assert prudent > monitor.scale  # the chain's noise is not known yet: more than ŝ
    spread2 = high.sd**2 + (prudent * high.noise) ** 2 + variance  # its last reading's too
    expected = value * (1 + 2 * math.sqrt(spread2))
    point = {**made.setpoint, **op.context}
    before = state.tools[unread].models["roughness_um"].predict(point)
    edge = (before.value + before.band) * math.exp(shift)
    from_edge = edge * (1 + 2 * math.sqrt(variance))
    # here the band's edge is the higher: the last reading alone would cover 4.018 um, and
    # a truth up to the band's edge before the change would cross at the next part
    assert from_edge > expected
    covered = from_edge
    after = new.tools[unread].models["roughness_um"].predict(point)
    assert before.value + before.band < covered  # it did not cover the change before
    limit = op.limits["roughness_um"]
    assert covered > limit
    settings = state.settings
    reach = covered * (covered / limit) ** (settings.coverage_k * settings.exponent_sd)
    assert after.value + after.band == pytest.approx(reach, rel=1e-6)


def test_a_failed_sensor_at_the_change_neither_hides_the_rise_nor_pulls_it_down():
    # five readings at 3 sigma (e = 0.12, v = 0.0016) and one at 30 % of the truth that escaped
    # quarantine (e = -0.8: r = -20): counted at -2 sigma, e = -0.08. Z = (15 - 2)/sqrt(6) =
    # 5.307 (unclipped: -2.04, no change found); w = 625 each, mean 0.52/6 = 0.08667,
    # Q = 625 x (5 x 0.03333^2 + 0.16667^2) = 20.833, scale 3750 - 625 = 3125,
    # tau^2 = (20.833 - 5)/3125 = 0.0050667
    innovations = [(0.12, 0.0016)] * 5 + [(-0.8, 0.0016)]
    (found,) = cc.common_shifts([("roughness_um", i) for i in innovations]).values()
    assert found.z == pytest.approx(13 / math.sqrt(6))
    assert found.tau2 == pytest.approx((125 / 6 - 5) / 3125)
    assert found.shift() == pytest.approx((0.52 / 6, 0.0016 / 6 + found.tau2 * 7 / 6))
    # the failed one moves by the other five's 0.12, variance (0.0016 + tau^2)/5 + tau^2
    assert found.shift(without=5) == pytest.approx((0.12, 0.0064), rel=1e-9)
