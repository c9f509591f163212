"""Whether a plan's readings confirm a change its monitors counted (supervisor/fleet/changes.py).

Worked numbers: ``z = |φ·Δμ| / √(φᵀ(Σ_now + Σ_before)φ)`` at ``φ = (1, x)``, ``x = −Σ_xx⁻¹ Σ_x0``
of the newer belief, where its ``ln Y`` is best known.
"""

from __future__ import annotations

import math

import pytest

from supervisor.fleet.changes import CONFIRM_Z, Shift, confirmed, largest_shift, shift_z
from supervisor.rcb.posterior import Posterior


def _belief(mean: tuple[float, ...], cov: tuple[tuple[float, ...], ...]) -> Posterior:
    names = ("feed_mm_rev",) * (len(mean) - 1)
    return Posterior("force_N", names, (0.0,) * len(names), {}, mean, cov)


def test_an_intercept_alone_shifts_by_its_difference_over_both_spreads() -> None:
    before = _belief((0.0,), ((0.02**2,),))
    now = _belief((0.1,), ((0.03**2,),))
    assert shift_z(before, now) == pytest.approx(0.1 / math.sqrt(0.02**2 + 0.03**2))  # 2.774


def test_the_shift_is_read_where_the_newer_belief_is_best_known() -> None:
    """Σ_now = [[0.05, 0.02], [0.02, 0.01]]: x = −0.02/0.01 = −2, φ = (1, −2); φᵀΣ_nowφ =
    0.05 − 0.08 + 0.04 = 0.01. Δμ = (0.3, 0.1): φ·Δμ = 0.1. With Σ_before = Σ_now, z =
    0.1/√0.02 = 0.707; at the centre (φ = (1, 0)) it would have read 0.3/√0.1 = 0.949."""
    cov = ((0.05, 0.02), (0.02, 0.01))
    assert shift_z(_belief((0.0, 0.0), cov), _belief((0.3, 0.1), cov)) == pytest.approx(
        0.1 / math.sqrt(0.02)
    )


def _labelled(*pairs):  # type: ignore[no-untyped-def]
    """``(before, now)`` beliefs per quantity "op i", i counting the pairs."""
    keys = [("op", str(i)) for i in range(len(pairs))]
    before = {key: old for key, (old, _) in zip(keys, pairs, strict=True)}
    return before, {key: now for key, (_, now) in zip(keys, pairs, strict=True)}


def test_a_change_is_confirmed_by_any_quantity_and_by_nothing_to_compare() -> None:
    steady = (_belief((0.0,), ((1e-4,),)), _belief((0.005,), ((1e-4,),)))  # z 0.35
    moved = (_belief((0.0,), ((1e-4,),)), _belief((0.05,), ((1e-4,),)))  # z 3.54
    assert shift_z(*moved) > CONFIRM_Z > shift_z(*steady)
    assert not confirmed(*_labelled(steady, steady))
    assert confirmed(*_labelled(steady, moved))
    assert confirmed(*_labelled((None, steady[1])))  # nothing learned before the change
    assert not confirmed(*_labelled((steady[0], None)))  # nothing learned since: no evidence


def test_the_largest_shift_names_its_quantity() -> None:
    """0.05/√(2·10⁻⁴) = 3.536 in "op 1"; 0.005/√(2·10⁻⁴) = 0.354 in "op 0"; a quantity with
    nothing learned before it is named with no ``z``, whatever the others read."""
    steady = (_belief((0.0,), ((1e-4,),)), _belief((0.005,), ((1e-4,),)))
    moved = (_belief((0.0,), ((1e-4,),)), _belief((0.05,), ((1e-4,),)))
    shift = largest_shift(*_labelled(steady, moved, steady))
    assert shift is not None and shift.where == "op 1"
    assert shift.z == pytest.approx(0.05 / math.sqrt(2e-4)) and shift.confirms
    shift = largest_shift(*_labelled(steady, steady))
    assert shift is not None and shift.z == pytest.approx(0.005 / math.sqrt(2e-4))
    assert not shift.confirms
    assert largest_shift(*_labelled(moved, (None, steady[1]))) == Shift("op 1", None)
    assert largest_shift(*_labelled((steady[0], None))) is None
