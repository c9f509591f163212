"""A belief keeps what its readings alone say (:mod:`supervisor.rcb.information`).

Checked against routes that do not use it: a step in covariance form (``Σ + v e₀e₀ᵀ``
inverted), the same updates from a start a million times wider (whose precision is then the
readings' own to a millionth of the start's), and ``P − P₀``, which is the readings' own
wherever no step was taken.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from supervisor.fleet.evidence import evidence
from supervisor.inputs.part_report import Measurement
from supervisor.inputs.plan import load_plan
from supervisor.rcb import information
from supervisor.rcb import posterior as post
from supervisor.rcb.learning import discount, rescaled, shifted
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start
from supervisor.virtual.fault_spec import parse_faults
from supervisor.virtual.scenario import run_scenario

PLAN = load_plan(Path(__file__).resolve().parents[2] / "examples" / "ivester_demo_part.toml")
ROUGH_OD = PLAN.operations[0]  # force_N with the edge feature: parts_per_edge = 10
FORCE = PLAN.tools[ROUGH_OD.tool].models["force_N"]

#: A reading: feed and speed within rough-od's box, an edge age, ln of the reading's offset.
READING = st.tuples(
    st.floats(0.0, 1.0), st.floats(0.0, 1.0), st.integers(0, 9), st.floats(-0.3, 0.3)
)


def _start(widen: float = 1.0) -> post.Posterior:
    """rough-od's catalogue prior of force, every variance times ``widen``."""
    start = post.prior(FORCE, ROUGH_OD, 2.0, post.DEFAULT_EXPONENT_SD)
    return replace(start, cov=tuple(tuple(widen * v for v in row) for row in start.cov))


def _point(a: float, b: float) -> dict[str, float]:
    (f0, f1), (v0, v1) = ROUGH_OD.bounds["feed_mm_rev"], ROUGH_OD.bounds["speed_m_min"]
    depth = ROUGH_OD.bounds["depth_mm"][1]
    return {"feed_mm_rev": f0 + a * (f1 - f0), "speed_m_min": v0 + b * (v1 - v0), "depth_mm": depth}


def _learned(
    belief: post.Posterior, readings: list, step_after: int, step: float
) -> post.Posterior:
    """``belief`` after ``readings`` (2 % noise), ``ln K`` stepped after ``step_after``."""
    for i, (a, b, age, offset) in enumerate(readings):
        if i == step_after:
            belief = discount(belief, step)
        point = {**_point(a, b), **ROUGH_OD.context}
        y = FORCE.predict(point).value * math.exp(offset)
        belief = post.observe(belief, point, Measurement(y, 0.04 * y), 2.0, 0.0, age)
    return belief


def _held(entries: list[float]) -> post.Posterior:
    """A belief of 3 parameters whose readings' ``J`` (full rank) and ``h`` are ``entries``."""
    a = np.array(entries[:9]).reshape(3, 3)
    j = a @ a.T + 0.1 * np.eye(3)
    return post.Posterior(
        "force_N",
        ("feed_mm_rev", "speed_m_min"),
        (0.0, 0.0),
        {},
        (0.0, 0.0, 0.0),
        tuple(tuple(row) for row in np.linalg.inv(j + np.eye(3))),
        readings_information=tuple(tuple(row) for row in j),
        readings_vector=tuple(entries[9:]),
    )


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=12, max_size=12), st.floats(1e-4, 1.0))
def test_a_step_is_the_covariance_forms(entries: list[float], variance: float) -> None:
    """For a full-rank ``J``: ``J' = (J⁻¹ + v e₀e₀ᵀ)⁻¹`` and ``h' = J' J⁻¹ h``."""
    belief = _held(entries)
    j, h = np.array(belief.readings_information), np.array(belief.readings_vector)
    stepped = information.stepped(belief, variance)
    cov = np.linalg.inv(j)
    cov[0, 0] += variance
    expected = np.linalg.inv(cov)
    np.testing.assert_allclose(stepped.readings_information, expected, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(stepped.readings_vector, expected @ np.linalg.solve(j, h), atol=1e-9)
    assert stepped.cov[0][0] == belief.cov[0][0] + variance


@settings(max_examples=40, deadline=None)
@given(st.lists(READING, min_size=1, max_size=12))
def test_without_a_step_the_readings_are_the_posterior_less_its_start(readings: list) -> None:
    start = _start()
    belief = _learned(start, readings, len(readings), 0.0)
    j, h = np.array(belief.readings_information), np.array(belief.readings_vector)
    scale = float(np.abs(j).max())
    np.testing.assert_allclose(j, belief.precision - start.precision, atol=1e-8 * scale)
    vector = belief.precision @ belief.mean_array - start.precision @ start.mean_array
    np.testing.assert_allclose(h, vector, atol=1e-8 * float(np.abs(h).max()) + 1e-9)


@settings(max_examples=40, deadline=None)
@given(st.lists(READING, min_size=4, max_size=12), st.integers(1, 3), st.floats(1e-3, 0.1))
def test_after_a_step_the_readings_are_what_a_flat_start_learns(
    readings: list, step_after: int, step: float
) -> None:
    """The readings' own: the same updates from a start 1e6 times wider."""
    belief = _learned(_start(), readings, step_after, step)
    flat = _learned(_start(1e6), readings, step_after, step)
    j = np.array(belief.readings_information)
    atol = 1e-5 * float(np.abs(_start().precision).max())
    np.testing.assert_allclose(j, flat.precision, atol=atol)


def test_reweighing_after_a_step_keeps_what_the_step_took() -> None:
    """A noise scale going up (``ρ = 1/4``) after a change's discount: the readings weigh less
    and the start's part stays, so ``ln K``'s variance only grows. The formula before
    2026-12-06, ``P₀ + ρ(P − P₀)`` (still that of a belief stored without its readings),
    gave back nearly all the discount took: ``ln K``'s variance 0.0016, the discounted
    belief's 0.051."""
    start = _start()
    readings = [(0.2, 0.8, 1, 0.1), (0.9, 0.1, 2, 0.12), (0.5, 0.5, 3, 0.08), (0.1, 0.3, 4, 0.1)]
    belief = _learned(start, readings, 4, 0.0)
    stepped = discount(belief, 0.05)
    again = rescaled(stepped, start, 4.0)
    j, j_again = np.array(stepped.readings_information), np.array(again.readings_information)
    np.testing.assert_allclose(j_again, 0.25 * j, rtol=1e-12)
    np.testing.assert_allclose(
        again.precision - j_again, stepped.precision - j, atol=1e-8 * np.abs(j).max()
    )
    assert again.cov[0][0] > stepped.cov[0][0]
    assert np.linalg.eigvalsh(np.array(again.cov) - np.array(stepped.cov)).min() > -1e-12
    stored_before = replace(stepped, readings_information=None, readings_vector=None)
    old = rescaled(stored_before, start, 4.0)
    assert old.cov[0][0] < 0.1 * stepped.cov[0][0]


def test_a_belief_stored_before_keeps_its_old_reading() -> None:
    """JSON round trip; a belief stored without them reads ``P − P₀``'s positive part."""
    start = _start()
    belief = _learned(start, [(0.3, 0.6, 2, 0.05), (0.7, 0.2, 5, -0.02)], 2, 0.0)
    assert post.from_json(belief.to_json()) == belief
    stored = belief.to_json()
    del stored["readings_information"], stored["readings_vector"]
    old = post.from_json(stored)
    assert old.readings_information is None and "readings_vector" not in old.to_json()
    j, _ = information.readings_of(old, start)
    np.testing.assert_allclose(j, belief.readings_information, atol=1e-8 * np.abs(j).max())


@pytest.mark.parametrize("step", [0.0, 0.02])
def test_the_fleet_reads_the_readings_own_about_the_tools_law(step: float) -> None:
    """``evidence`` maps ``(J, h)`` to ``θ = (ln K, e…, ω)``: without a step the same as
    ``P − P₀`` (the reading of a belief stored before); after one it keeps the exponents'
    evidence whole where ``P − P₀``'s positive part lost some of it."""
    start = _start()
    readings = [(a / 7, (7 - a) / 7, a, 0.05 * (a % 3)) for a in range(8)]
    belief = _learned(start, readings, 5, step)
    old = replace(belief, readings_information=None, readings_vector=None)
    new, before = (evidence(b, start, ROUGH_OD.context) for b in (belief, old))
    if step == 0.0:
        scale = float(np.abs(new.information).max())
        np.testing.assert_allclose(new.information, before.information, atol=1e-7 * scale)
        np.testing.assert_allclose(new.vector, before.vector, atol=1e-7 * np.abs(new.vector).max())
        return
    # the feed exponent's information given ln K: every reading's, less nothing the step took
    feed = 1 + belief.names.index("feed_mm_rev")
    assert new.information[feed, feed] > 1.05 * before.information[feed, feed]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=12, max_size=12), st.floats(-0.3, 0.3))
def test_a_shift_moves_the_readings_own_mean_as_the_belief(entries: list[float], d: float) -> None:
    """``J⁻¹ h`` moves by ``d`` in ``ln K`` and nothing else; ``J`` stays."""
    belief = _held(entries)
    moved = shifted(belief, d)
    assert moved.mean[0] == belief.mean[0] + d and moved.mean[1:] == belief.mean[1:]
    assert moved.readings_information == belief.readings_information
    j = np.array(belief.readings_information)
    change = np.linalg.solve(j, moved.readings_vector) - np.linalg.solve(j, belief.readings_vector)
    np.testing.assert_allclose(change, [d, 0.0, 0.0], atol=1e-9)


def test_a_step_of_the_process_teaches_no_false_exponent() -> None:
    """``closed_loop.py --fault step:15:1.12``, seed 32: the common change moves the
    intercept at part 15; with the readings' own mean left where it was, each new noise
    scale pulled the belief back towards the old level, the feed exponent of finish-od's
    roughness went 1.13 → 1.08 and the limit was crossed at parts 24-29 (a version of this
    change before it was committed). Only the step's own part crosses."""
    plan, seed = PLAN, 32
    trace = run_scenario(
        start(plan, RcbSettings(strategy="learn")), seed, 30, faults=parse_faults(["step:15:1.12"])
    )
    assert {part for part, _, _ in trace.where} == {15}
