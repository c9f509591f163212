"""One operation's spike past its limit: a breach of that operation, no one else's change.

A process engineer's audit (2026-12-04): on a plan of three roughing operations, one reading
of 2600 N where 1455 N was expected (limit 1500 N) halted the plan, but its decision was
``hold``/``shrink`` with no flag ("inside the learned cone"), the report said "0 past a limit",
and the two other operations, which read +0.9σ and +0.2σ, were each noted ``regime_change``
with margins of -900 N (each counted a change of its process: three changes to accept). The
spike made Stouffer's pooled ``Z`` 81 alone (:mod:`supervisor.rcb.common_cause`): every
operation was learned at a shared shift, and the spiking reading itself was judged at that
shift's wide ``u``, under which 2600 N was no breach. Now an innovation counts at most at the
one-reading alarm's 4σ in ``Z``, and a reading learned at a common shift keeps its own flag.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from supervisor.inputs.part_report import Measurement, PartReport
from supervisor.inputs.plan import load_plan
from supervisor.rcb import common_cause as cc
from supervisor.rcb.decision import Decision
from supervisor.rcb.shop_floor import own_flags
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start, update

from conftest import ROOT


def test_one_operations_spike_is_not_every_operations_change():
    # r = 140, 0.9, 0.2 (v = 0.0016, sd 0.04): unbounded Z = 141.1/sqrt(3) = 81.46 > 3.5;
    # the spike counted at 4: Z = 5.1/sqrt(3) = 2.944, no common change
    innovations = [(140 * 0.04, 0.0016), (0.9 * 0.04, 0.0016), (0.2 * 0.04, 0.0016)]
    assert cc.pooled_sigma(innovations) == pytest.approx(141.1 / math.sqrt(3))
    assert cc.common_shifts([("force_N", i) for i in innovations]) == {}


def test_a_shared_rise_with_one_spike_is_still_a_change_learned_at_the_raw_shift():
    # r = 5, 5, 100: Z = (4 + 4 + 4)/sqrt(3) = 6.928; the shift is of the readings as read
    innovations = [(0.20, 0.0016), (0.20, 0.0016), (4.0, 0.0016)]
    (found,) = cc.common_shifts([("force_N", i) for i in innovations]).values()
    assert found.z == pytest.approx(12 / math.sqrt(3))
    assert found.innovations == tuple(innovations)
    assert found.shift(without=2)[0] == pytest.approx(0.20)


def _decision(**kw: object) -> Decision:
    base = {
        "operation": "rough-od",
        "quantity": "force_N",
        "action": "shrink",
        "margin": -1356.3,
        "band_before": 44.4,
        "band_after": 30.2,
        "dK_before": 65.6,
        "dK_after": 44.5,
        "K_before": 2147.0,
        "K_after": 3836.0,
        "predicted": 1454.7,
        "measured": 1489.8,
        "uncertainty": 1366.5,
        "limit": 1500.0,
        "flagged": False,
        "reason": "inside the learned cone; the fallback band grows to cover it",
    }
    return Decision(**{**base, **kw})  # type: ignore[arg-type]


def test_a_reading_learned_at_the_shift_keeps_its_own_breach():
    # the audit's numbers: learned at the shift 1489.8 ± 1366.5 N, read 2600 ± 15 N
    shifted = _decision()
    own = _decision(
        action="expand",
        measured=2600.0,
        uncertainty=15.0,
        flagged=True,
        flag="breach",
        reason="measured − 3σ past the limit: never shrink; band covers it",
    )
    done = own_flags(shifted, own)
    assert (done.flag, done.flagged, done.note, done.action) == ("breach", True, None, "hold")
    assert done.reason == (
        "measured − 3σ past the limit: never shrink; band covers it; the band covers the "
        "shift the part's other operations showed"
    )
    assert (done.margin, done.band_after, done.K_after) == (-1356.3, 30.2, 3836.0)  # shift's
    assert own_flags(shifted, replace(own, flagged=False, flag=None)) is shifted
    part = own_flags(shifted, replace(own, flagged=False, flag=None, note="past_limit"))
    assert (part.flag, part.note, part.action) == (None, "past_limit", "shrink")


def _virtual_lathe(spike_N: float):  # type: ignore[no-untyped-def]
    """The audit's plan (examples/virtual_lathe_part.toml, three roughing cuts, force limits
    1500 / 600 / 600 N), ``learn``: ten parts read at the prediction ± 1 % (u 15 N on rough-od,
    8 N on the others), then one with rough-od read at ``spike_N``. The state, the decisions."""
    state = start(load_plan(ROOT / "examples" / "virtual_lathe_part.toml"), RcbSettings())
    rng = np.random.default_rng(1)
    for k in range(11):
        readings = {}
        for op in state.setpoints.operations:
            value = op.predicted["force_N"].value * (1 + 0.01 * rng.standard_normal())
            if k == 10 and op.name == "rough-od":
                value = spike_N
            u = 15.0 if op.name == "rough-od" else 8.0
            readings[op.name] = {"force_N": Measurement(round(value, 1), u)}
        state, decisions = update(state, PartReport(f"P-{k}", state.version, readings))
    return state, decisions


@pytest.mark.parametrize("bounded", [True, False])
def test_a_spike_past_its_limit_is_a_breach_and_the_others_carry_on(bounded, monkeypatch):
    """``bounded`` False: the pooled ``Z`` unbounded above as before, so the spike still makes
    a common shift, learned at its wide ``u``: the reading's own breach stands all the same
    (shop_floor.own_flags)."""
    if not bounded:
        monkeypatch.setattr(cc, "CEILING_SIGMA", math.inf)
    after, decisions = _virtual_lathe(2600.0)
    by = {d.operation: d for d in decisions}
    spike = by["rough-od"]
    assert (spike.flag, spike.flagged, spike.measured) == ("breach", True, 2600.0)
    assert after.halt is not None  # 73 % over: past halt_over's 25 %
    others = [d for op, d in by.items() if op != "rough-od"]
    assert len(others) == 2 and all(not d.flagged for d in others)
    noted = [d.note for d in others]
    assert noted == ([None, None] if bounded else ["regime_change", "regime_change"])
    if bounded:  # their margins of their own readings, near their 600 N limits (was -900 N)
        assert all(abs(d.margin or 0.0) < 10.0 for d in others)
    else:  # learned at the shift: the margins the audit saw
        assert all((d.margin or 0.0) < -500.0 for d in others)
