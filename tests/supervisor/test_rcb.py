"""Recursive Constraint Bounding: the law with hand-computed numbers, replay, strategies."""

from __future__ import annotations

from dataclasses import replace

import pytest
from numpy.testing import assert_allclose
from rcb_support import _report, paper_start

from supervisor.inputs.part_report import Measurement, ToolWear
from supervisor.inputs.plan import load_plan
from supervisor.optimize.optimizer import optimize_plan
from supervisor.rcb.law import apply_law
from supervisor.rcb.monitor_state import Monitor
from supervisor.rcb.noise import NoiseScale
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start, update

from conftest import DEMO_PLAN

#: The chain's prudent noise scale before any reading has shown its noise (supervisor.rcb.noise:
#: the inverse-gamma prior a = 1.5, b = 1 and its upper 93 % quantile, b / P⁻¹(a, 0.07)).
PRUDENT = 2.1111458
#: Its bound scale: the same prior's upper Φ(2) = 97.725 % quantile, b / P⁻¹(a, 0.02275),
#: the k = 2 of the paper's y + u with the chain's noise not yet known (supervisor.rcb.law).
BOUND = 3.1458193


def test_the_prudent_scale_before_any_reading():
    assert NoiseScale().prudent_scale == pytest.approx(PRUDENT, rel=1e-7)
    assert NoiseScale().bound_scale == pytest.approx(BOUND, rel=1e-7)
    assert NoiseScale().scales() == (NoiseScale().prudent_scale, NoiseScale().bound_scale)


@pytest.fixture(scope="module")
def state():
    return paper_start()


def _rough_od(state):
    return state.setpoints.operations[0]


def test_a_margin_shrinks_the_band_by_a_quarter_of_it(state):
    # rough-od robust start: Ra 3.176 ± 0.8235 µm, limit 4.0 µm (Ivester & Heigel Table 4).
    # Measured 3.06 ± 0.09 µm (Table 5 step 1 row R): margin = 4.0 − 3.15 = 0.85 µm,
    # new band = 0.8235 − 0.25 · 0.85 = 0.6110 µm, new ΔK = 14 · 0.6110 / 0.8235 = 10.387 µm.
    ra = _rough_od(state).predicted["roughness_um"]
    new, (d,) = update(
        state, _report(state, {"rough-od": {"roughness_um": Measurement(3.06, 0.09)}})
    )
    assert d.action == "shrink" and not d.flagged
    assert_allclose(d.margin, 0.85)
    assert_allclose(d.band_before, ra.band)
    assert_allclose(d.band_after, ra.band - 0.25 * 0.85)
    assert_allclose(d.dK_after, 14 * (ra.band - 0.25 * 0.85) / ra.band)
    assert_allclose(d.dK_after, 10.387, rtol=1e-4)
    assert new.tools["rough-od"].models["roughness_um"].dK == d.dK_after
    assert new.version == state.version + 1
    assert new.setpoints.operations[0].mrr_cm3_min > _rough_od(state).mrr_cm3_min
    # catalogue K untouched by the ivester strategy; other operations keep their bands
    assert new.tools["rough-od"].models["roughness_um"].K == 54
    assert new.tools["finish-od"] == state.tools["finish-od"]


def test_the_floor_holds(state):
    # Measured at the prediction: margin = ΔY − u, so ΔY' = ΔY − 0.25(ΔY − u) tends to the
    # floor u = 0.09 µm, never below; and the band keeps covering the most demanding
    # measurement so far: the first, y + u = Y_R + 0.09 at Y_R = 3.176 µm, i.e. a relative
    # band of 0.09 / 3.176 = 2.83 % wherever the setpoint goes.
    s = state
    first = _rough_od(s).predicted["roughness_um"].value
    for _ in range(20):
        ra = _rough_od(s).predicted["roughness_um"]
        s, (d,) = update(s, _report(s, {"rough-od": {"roughness_um": Measurement(ra.value, 0.09)}}))
        assert d.band_after >= 0.09 - 1e-12
        assert d.band_after / d.predicted >= 0.09 / first - 1e-12
    assert_allclose(d.band_after / d.predicted, 0.09 / first, rtol=0.02)
    # A floor set for the quantity: 0.8235 − 0.25·(0.8235 − 0.09) = 0.640 stops at 0.7 µm.
    custom = replace(state, settings=RcbSettings(strategy="ivester", floors={"roughness_um": 0.7}))
    ra = _rough_od(custom).predicted["roughness_um"]
    measured = {"rough-od": {"roughness_um": Measurement(ra.value, 0.09)}}
    _, (d2,) = update(custom, _report(custom, measured))
    assert d2.action == "shrink"
    assert_allclose(d2.band_after, 0.7)


def test_a_violation_expands_and_never_shrinks(state):
    # Ra 4.3 ± 0.05 µm is over the 4.0 µm limit: a breach; the band grows to cover it, its u
    # at the chain's bound scale (no reading has shown the chain's noise yet: the prior's
    # upper Φ(2) quantile, Q = 3.1458, supervisor.rcb.noise; P = 2.1111 before 2026-12-06)
    ra = _rough_od(state).predicted["roughness_um"]
    new, (d,) = update(
        state, _report(state, {"rough-od": {"roughness_um": Measurement(4.3, 0.05)}})
    )
    assert d.action == "expand" and d.flagged and d.flag == "breach" and d.note is None
    assert_allclose(d.band_after, 4.3 + BOUND * 0.05 - ra.value)  # y + Q u − Y
    assert d.band_after > d.band_before and d.margin < 0
    assert new.setpoints.operations[0].mrr_cm3_min < _rough_od(state).mrr_cm3_min  # backs off


def test_one_sided_law_hand_computed(state):
    # rough-grooves robust start (Ivester & Heigel Table 4 models, VCMR331) at its grid setpoint
    # d 3, f 0.1008, v 200 (continuous f 0.100842: 578.53 ± 177.10 N): force Y = 578.35 N,
    # ΔY = 177.05 N, so the band is [401.30, 755.40] N under the 1000 N limit.
    f = state.setpoints.operations[1].predicted["force_N"]
    assert state.setpoints.operations[1].setpoint["feed_mm_rev"] == 0.1008
    assert_allclose((f.value, f.band), (578.35, 177.05), atol=0.01)

    def one(y, u):
        measured = {"rough-grooves": {"force_N": Measurement(y, u)}}
        return update(state, _report(state, measured))[1][0]

    # under the lower edge: 380 ± 5 → margin M = 1000 − 385 = 615 N; the band shrinks by
    # exactly 0.25 M = 153.75 N to 23.35 N (above the 5 N floor); a note, never a flag
    low = one(380.0, 5.0)
    assert low.action == "shrink" and not low.flagged and low.flag is None
    assert low.note == "below_band"
    assert_allclose(low.margin, 615.0)
    assert_allclose(low.band_after, f.band - 153.75)
    # above the upper edge, under the limit: 760 ± 5 → y + u = 765 > 755.40: flagged
    # above_band; the band grows to cover it at the chain's bound scale, y + Q u = 775.73 N
    # (197.38 N over the prediction; the paper's y + u, 186.65 N, left a reading 2σ low to
    # cross at the grown band's edge, y + P u, 192.21 N, one 4.2σ low); over the prediction
    # by more than (Q − 1) u, the margin reads y + Q u: 1000 − 775.73 = 224.27 N (the
    # paper's 235 N)
    above = one(760.0, 5.0)
    assert above.action == "expand" and above.flagged and above.flag == "above_band"
    assert above.note is None
    assert_allclose(above.band_after, 760.0 + BOUND * 5.0 - f.value)
    assert_allclose(above.band_after, 197.38, atol=0.01)
    assert_allclose(above.margin, 1000.0 - 760.0 - 5 * BOUND)
    assert_allclose(above.margin, 224.27, atol=0.01)
    # over the prediction, inside the band: 620 ± 5, margin 1000 − 635.73 = 364.27 N, the band
    # shrinks by 91.07 N to 85.98 N (the paper's y + u: 375 N, 93.75 N; it still covers
    # y + u = 625 N, 46.65 N over the prediction)
    upper_half = one(620.0, 5.0)
    assert upper_half.action == "shrink" and upper_half.flag is None
    assert_allclose(upper_half.margin, 364.27, atol=0.01)
    assert_allclose(upper_half.band_after, f.band - 0.25 * (1000.0 - 620.0 - 5 * BOUND))
    assert_allclose(upper_half.band_after, 85.98, atol=0.01)
    # just over the prediction: 580 ± 5, δ = 1.65 N under (Q − 1) u = 10.73 N: the margin
    # counts u + δ, 1000 − 586.65 = 413.35 N (the paper's 415 N); continuous at y = Y
    just_over = one(580.0, 5.0)
    assert just_over.action == "shrink" and just_over.flag is None
    assert_allclose(just_over.margin, 1000.0 - 580.0 - 5.0 - (580.0 - f.value))
    assert_allclose(just_over.margin, 413.35, atol=0.01)
    # near the limit, before the chain has shown its noise, u counts at the prudent scale P
    # where y + P u is past the limit: 990 ± 5 → 990 + 5 P = 1000.56 > 1000, flagged, and the
    # band covers y + Q u (1005.73 − 578.35 = 427.38 N); 985 ± 5 → 995.56 under it: flagged at
    # y + u, the band covers y + Q u all the same (422.38 N; y + P u, 417.21 N, before
    # 2026-12-06; y + u, 411.65 N, before 2026-12-05)
    near = one(990.0, 5.0)
    assert near.flag == "above_band" and near.action == "expand"
    assert_allclose(near.band_after, 990.0 + 5 * BOUND - f.value)
    assert_allclose(near.band_after, 427.38, atol=0.01)
    assert_allclose(near.margin, 1000.0 - 990.0 - 5 * BOUND, atol=1e-6)  # −5.73 N: none
    under = one(985.0, 5.0)
    assert under.flag == "above_band"
    assert_allclose(under.band_after, 985.0 + 5 * BOUND - f.value)
    assert_allclose(under.band_after, 422.38, atol=0.01)
    # measured over the limit: 1010 ± 5 → breach, the band covers 1010 + 5 Q = 1025.73 N
    over = one(1010.0, 5.0)
    assert over.action == "expand" and over.flag == "breach"
    assert_allclose(over.band_after, 1010.0 + 5 * BOUND - f.value)
    assert_allclose(over.margin, -10.0 - 5 * BOUND)
    # past the limit by more than u but within the reading's 3σ (σ = u/2): 1006 ± 5 → y − u
    # = 1001 > 1000 (out of tolerance by ISO 14253-1: the note past_limit), y − 1.5u = 998.5
    # under it (no process alarm); a band setpoint still flags it above_band and backs off
    iso = one(1006.0, 5.0)
    assert iso.flag == "above_band" and iso.note == "past_limit" and iso.action == "expand"
    assert_allclose(iso.band_after, 1006.0 + 5 * BOUND - f.value)
    assert_allclose(iso.margin, -6.0 - 5 * BOUND)
    # the 3σ alarm's edge: y − 1.5u = 1000.0 is not past the limit, 1000.15 is
    assert one(1007.5, 5.0).flag == "above_band"
    assert one(1007.65, 5.0).flag == "breach" and one(1007.65, 5.0).note is None
    # inside the band: an ordinary shrink, neither flag nor note
    inside = one(600.0, 5.0)
    assert inside.action == "shrink" and inside.flag is None and inside.note is None


def test_one_sided_law_mirrored_for_tool_life(state):
    # Tool life is a minimum: rough-od needs 10 parts x 86400 mm³ = 864000 mm³ per edge.
    op = state.plan.operations[0]
    point = {**_rough_od(state).setpoint, **op.context}
    life = state.tools["rough-od"].models["tool_life_mm3"].predict(point)
    limit = 10 * 86400

    def wear_for(volume_at_allowable):
        # Eq. 8, mr ∝ w^1.241: an edge at VB after V reaches 0.3 mm after V (0.3/VB)^1.241
        vb = 0.15
        return ToolWear(Measurement(vb, 0.001), volume_at_allowable / (0.3 / vb) ** 1.241)

    # far above the band's upper edge: the note above_band, a shrink by 0.25 of the margin
    high = life.upper * 1.2
    _, (d,) = update(state, _report(state, {}, {"rough-od": wear_for(high)}))
    assert d.note == "above_band" and not d.flagged and d.action == "shrink"
    assert_allclose(d.margin, (d.measured - d.uncertainty) - limit)
    assert_allclose(d.band_after, d.band_before - 0.25 * d.margin)
    # under the lower edge, over the limit: flagged below_band, the band grows
    between = 0.5 * (limit + life.lower)
    assert limit < between < life.lower
    _, (d,) = update(state, _report(state, {}, {"rough-od": wear_for(between)}))
    assert d.flag == "below_band" and d.action == "expand"
    assert_allclose(d.band_after, life.value - (d.measured - d.uncertainty))
    # y + u under the limit, y + 1.5u not (u = V·1.241·0.001/0.15, so V = L/1.01 gives
    # y + u = 0.99821 L and y + 1.5u = 1.00239 L): out of tolerance, no alarm
    _, (d,) = update(state, _report(state, {}, {"rough-od": wear_for(limit / 1.01)}))
    assert_allclose(d.uncertainty / d.measured, 1.241 * 0.001 / 0.15)
    assert d.flag == "below_band" and d.note == "past_limit" and d.action == "expand"
    # under the limit: breach
    _, (d,) = update(state, _report(state, {}, {"rough-od": wear_for(0.5 * limit)}))
    assert d.flag == "breach" and d.action == "expand" and d.margin < 0


def test_no_margin_holds():
    # measured + u exactly on the limit and on the band's upper edge: no margin, inside the
    # band. On the machine's grid the robust start's edge lies below the 4.0 µm limit, so the
    # limit is set to that edge (the same setpoint: it met 4.0 and meets its own edge).
    plan = load_plan(DEMO_PLAN)
    settings = RcbSettings(strategy="ivester")
    edge = _rough_od(start(plan, settings)).predicted["roughness_um"].upper
    assert 3.99 < edge < 4.0
    rough = plan.operations[0]
    rough = replace(rough, limits={**rough.limits, "roughness_um": edge})
    state = start(replace(plan, operations=(rough, *plan.operations[1:])), settings)
    # a chain that has shown it is as quiet as it says (the evidence of 1000 half-readings at
    # 0.6 of its u²): its prudent scale is 1, the alarm reads u as reported
    quiet = Monitor(chain_shape=NoiseScale().shape + 500, chain_rate=NoiseScale().rate + 300)
    assert quiet.chain_noise.prudent_scale == 1.0
    state = replace(state, monitors={("rough-od", "roughness_um"): quiet})
    ra = _rough_od(state).predicted["roughness_um"]
    assert ra.upper == edge
    u = 0.0625  # a power of two: y + u is the edge to the last bit
    new, (d,) = update(
        state, _report(state, {"rough-od": {"roughness_um": Measurement(edge - u, u)}})
    )
    assert d.action == "hold" and not d.flagged and d.band_after == pytest.approx(ra.band)
    assert new.version == state.version  # nothing moved: no new setpoint version


def test_a_change_is_read_at_the_chains_bound_scale(state):
    # rough-grooves force at its robust start: Y = 578.35 N, band edge 755.40 N, limit 1000 N.
    # 745 ± 5 N: y + u = 750 is inside the band; before any reading the chain's P = 2.1111
    # and Q = 3.1458 (supervisor.rcb.noise). Read as a change (moved = s > 0), y + Q u =
    # 760.73 N is past the band's edge: above_band, and the band grows to cover it, 182.38 N
    # (under the limit: no exponent reach). The same reading with no change: the margin
    # counts u + δ up to Q u, 1000 − (745 + 15.73) = 239.27 N, and the band shrinks, by
    # 0.25 of it to 117.23 N but no further than covering y + u (171.65 N)
    made = state.setpoints.operations[1]
    op = state.plan.operations[1]
    f = made.predicted["force_N"]
    reading = Measurement(745.0, 5.0)
    scales = (5.0 * PRUDENT, 5.0 * BOUND)
    change, *_ = apply_law(state, op, made, "force_N", reading, 1.0, 0.15, *scales)
    assert change.flag == "above_band" and change.action == "expand"
    assert_allclose(change.band_after, 745.0 + 5.0 * BOUND - f.value)
    assert_allclose(change.band_after, 182.38, atol=0.01)
    quiet, *_ = apply_law(state, op, made, "force_N", reading, 1.0, 0.0, *scales)
    assert quiet.flag is None and quiet.action == "shrink"
    assert_allclose(quiet.margin, 239.27, atol=0.01)
    assert_allclose(quiet.band_after, 750.0 - f.value)


def test_quantities_and_operations_update_independently(state):
    both = {
        "rough-od": {"roughness_um": Measurement(3.06, 0.09), "force_N": Measurement(1990, 12)},
        "rough-grooves": {"roughness_um": Measurement(1.82, 0.07)},  # Table 5 step 2 row R
    }
    new, ds = update(state, _report(state, both))
    by = {(d.operation, d.quantity): d for d in ds}
    assert by[("rough-od", "roughness_um")].action == "shrink"
    # 1990 + 12 = 2002 is above the band's upper edge (the 2000 N limit): above_band
    assert by[("rough-od", "force_N")].action == "expand"
    assert by[("rough-od", "force_N")].flag == "above_band"
    grooves = by[("rough-grooves", "roughness_um")]
    assert grooves.action == "shrink"
    # 1.82 is δ = 0.098 µm over the 1.722 µm prediction, under (Q − 1) u = 0.150 µm: before
    # any reading has shown the chain's noise the margin counts u + δ, 2.0 − 1.988 = 0.012 µm
    # (the paper's y + u: 0.11 µm; supervisor.rcb.law); y + P u = 1.968 µm is under the limit,
    # so it is not flagged and the band shrinks, as in the paper
    assert grooves.predicted == pytest.approx(1.722, abs=5e-4)
    assert_allclose(grooves.margin, 2.0 - 1.82 - 0.07 - (1.82 - grooves.predicted), rtol=1e-6)
    assert_allclose(grooves.margin, 0.012, atol=5e-4)
    # steps 2 and 3 use the same insert (VCMR331) but keep separate bands
    assert new.tools["rough-contour"] == state.tools["rough-contour"]
    assert new.tools["rough-grooves"] != state.tools["rough-grooves"]


def test_only_the_operations_whose_bands_moved_are_re_optimised(state):
    measured = {"rough-grooves": {"roughness_um": Measurement(1.82, 0.07)}}
    new, _ = update(state, _report(state, measured))
    before = {r.name: r for r in state.setpoints.operations}
    after = {r.name: r for r in new.setpoints.operations}
    assert after["rough-grooves"] != before["rough-grooves"]  # its band shrank: new optimum
    for name in before.keys() - {"rough-grooves"}:
        assert after[name] is before[name]  # kept, not solved again
    # and what is kept is what a full re-optimisation gives
    assert new.setpoints == optimize_plan(new.plan, new.tools)


def test_tool_wear_goes_through_the_same_law(state):
    # Eq. 8: mr ∝ w^1.241. An edge at VB 0.15 ± 0.01 mm after 2.0e6 mm³ reaches the allowable
    # 0.3 mm after 2.0e6 · 2^1.241 = 4.728e6 mm³ (± 1.241 · 0.01/0.15 of it).
    wear = {"rough-od": ToolWear(Measurement(0.15, 0.01), 2.0e6)}
    _, (d,) = update(state, _report(state, {}, wear))
    assert d.quantity == "tool_life_mm3"
    assert_allclose(d.measured, 2.0e6 * 2**1.241)
    assert_allclose(d.uncertainty, d.measured * 1.241 * 0.01 / 0.15)
    assert_allclose(d.limit, 10 * 86400)  # parts_per_edge × volume
    assert_allclose(d.margin, (d.measured - d.uncertainty) - d.limit)


def test_replay_gives_identical_states(state):
    reports = [
        {"rough-od": {"roughness_um": Measurement(3.06, 0.09), "force_N": Measurement(1900, 12)}},
        {"rough-od": {"roughness_um": Measurement(3.5, 0.08)}},
        {"rough-grooves": {"roughness_um": Measurement(1.82, 0.07)}},
        {"rough-od": {"roughness_um": Measurement(4.2, 0.08)}},  # a violation
    ]

    def replay(settings):
        s = replace(start(state.plan, settings))
        trail = []
        for m in reports:
            s, ds = update(s, _report(s, m))
            trail.append(ds)
        return s, trail

    for strategy in ("ivester", "bayes"):
        a = replay(RcbSettings(strategy=strategy))
        b = replay(RcbSettings(strategy=strategy))
        assert a == b


def test_bayes_corrects_a_pessimistic_model_upward(state):
    # Measured Ra well below the prediction, again and again: bayes lowers K (the model was
    # pessimistic); ivester keeps the catalogue K = 54.
    s = start(state.plan, RcbSettings(strategy="bayes"))
    for _ in range(5):
        y = 0.85 * _rough_od(s).predicted["roughness_um"].value
        s, _ = update(s, _report(s, {"rough-od": {"roughness_um": Measurement(y, 0.05)}}))
    assert s.tools["rough-od"].models["roughness_um"].K < 54 * 0.95
    for op in s.setpoints.operations:  # still at or under every limit at the band edge
        assert op.predicted["roughness_um"].upper <= 4.0 * (1 + 1e-6) or op.name != "rough-od"


def test_the_band_keeps_covering_every_measurement_so_far(state):
    # Ivester & Heigel's bands are "the range of K that encompasses all of the points": after
    # shrinks at later setpoints, the band still reaches y + u of the first part at its setpoint.
    op = state.plan.operations[0]
    x_r = {**_rough_od(state).setpoint, **op.context}
    ra = _rough_od(state).predicted["roughness_um"]
    first = Measurement(ra.value + 0.2, 0.09)  # inside the band, 0.2 µm above the nominal
    s, _ = update(state, _report(state, {"rough-od": {"roughness_um": first}}))
    for _ in range(15):  # later parts measure low: each alone would shrink the band to the floor
        y = 0.97 * _rough_od(s).predicted["roughness_um"].value
        s, _ = update(s, _report(s, {"rough-od": {"roughness_um": Measurement(y, 0.09)}}))
    model = s.tools["rough-od"].models["roughness_um"]
    assert model.predict(x_r).upper >= first.value + first.uncertainty - 1e-9
    assert_allclose(model.predict(x_r).upper, first.value + first.uncertainty, rtol=1e-6)


def test_a_new_strategy_is_one_class(monkeypatch, state):
    # Issue 16: a strategy is one class in the registry; settings, the law and the state find
    # it by name. This one keeps at least 0.7 µm of band on Ra (a hand-made cautious rule).
    from supervisor.rcb import strategies

    class Cautious(strategies.Strategy):
        name = "cautious"
        summary = "the law, never under 0.7 of the band's unit"

        def least_band(self, band, sigma, value, coverage_k, discrepancy):
            return max(band, 0.7)

    monkeypatch.setitem(strategies.REGISTRY, "cautious", Cautious())  # type: ignore[index]
    plan = load_plan(DEMO_PLAN)
    mine = start(plan, RcbSettings(strategy="cautious"))
    report = _report(mine, {"rough-od": {"roughness_um": Measurement(3.06, 0.09)}})
    _, (d,) = update(mine, report)
    # the paper's law gives 0.8235 − 0.25 · 0.85 = 0.611 µm (the test above); Cautious 0.7
    assert d.action == "shrink"
    assert_allclose(d.band_after, 0.7)
    _, (paper,) = update(state, _report(state, report.measurements))
    assert_allclose(paper.band_after, _rough_od(state).predicted["roughness_um"].band - 0.2125)
