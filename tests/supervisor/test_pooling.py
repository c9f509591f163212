"""A fleet prior's operations of one tool pool their readings in the cones (issue 32).

The expected beliefs are worked from the Gaussian linear model in the tool's terms (Bishop
§3.3, the information form): every reading ``y ± u`` at ``x`` of either operation observes
``ln y − Σ_j e_j ln x_j = θ · (1, ln x, 0)`` with ``σ = (u/2)/y``, whatever operation took it
(:mod:`supervisor.rcb.pooling`, :mod:`supervisor.rcb.tool_terms`).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
from numpy.testing import assert_allclose

from supervisor.fleet.prior import Learned, fleet_priors
from supervisor.inputs.part_report import Measurement
from supervisor.inputs.plan import load_plan
from supervisor.rcb import learning
from supervisor.rcb import posterior as post
from supervisor.rcb.state import RcbSettings, RcbState
from supervisor.rcb.tool_terms import in_tool_terms
from supervisor.rcb.update import start

PLAN = load_plan(Path(__file__).resolve().parents[2] / "examples" / "ivester_demo_part.toml")
SETTINGS = RcbSettings(strategy="learn", discrepancy=0.0)
OPS = {op.name: op for op in PLAN.operations}
A, B = "rough-grooves", "rough-contour"  # both VCMR331, neither with an edge limit


def _fleet_state() -> RcbState:
    """A plan started from the prior of two machines that read 5 % over the catalogue."""
    learned = []
    for machine in ("m1", "m2"):
        for name in (A, B):
            op = OPS[name]
            belief = post.prior(
                PLAN.tools[op.tool].models["force_N"], op, 2.0, SETTINGS.exponent_sd
            )
            for factor, corner in ((1.05, 0.8), (1.05, 1.25), (1.04, 1.1)):
                point = {
                    n: math.exp(c) * corner
                    for n, c in zip(belief.names, belief.center, strict=True)
                }
                y = factor * math.exp(float(belief.features(point) @ belief.mean_array))
                belief = post.observe(belief, point, Measurement(y, 0.02 * y), 2.0, 0.0)
            learned.append(
                Learned(machine, f"p-{machine}", op, PLAN.tools[op.tool], belief, 2.0, 0.15)
            )
    priors = fleet_priors(PLAN, learned, 2.0, SETTINGS.exponent_sd)
    return start(PLAN, SETTINGS, {k: p.posterior for k, p in priors.items()})


def _read(state: RcbState, name: str, point: dict[str, float], y: float) -> RcbState:
    """``state`` with one force reading ``y ± 4 %`` of ``name`` at ``point`` learned."""
    op = OPS[name]
    before = state.posterior.get((name, "force_N"))
    if before is None:  # a catalogue start before its first reading
        model = PLAN.tools[op.tool].models["force_N"]
        before = post.prior(model, op, 2.0, SETTINGS.exponent_sd)
    belief = post.observe(before, point, Measurement(y, 0.04 * y), 2.0, 0.0)
    return replace(state, posterior={**state.posterior, (name, "force_N"): belief})


def _tool_feature(name: str, point: dict[str, float], y: float) -> tuple[np.ndarray, float]:
    """``(1, ln x, 0)`` and ``ln y − Σ_j e_j ln x_j`` of a reading of ``name``'s force."""
    belief = OPS_PRIOR[name]
    context = sum(e * math.log(OPS[name].context[n]) for n, e in belief.context_exponents.items())
    return np.array([1.0, *(math.log(point[n]) for n in belief.names), 0.0]), math.log(y) - context


STATE = _fleet_state()
OPS_PRIOR = {name: STATE.priors[(name, "force_N")] for name in (A, B)}
AT_A = {"depth_mm": 2.0, "feed_mm_rev": 0.3, "speed_m_min": 180.0}
AT_B = {"depth_mm": 1.0, "feed_mm_rev": 0.15, "speed_m_min": 90.0}


def test_a_cone_counts_the_other_operations_readings_as_one_regression_would() -> None:
    """One force reading on each operation: A's cone is the prior with both readings."""
    state = _read(_read(STATE, A, AT_A, 820.0), B, AT_B, 350.0)
    cone = learning.cones(state)[A]["force_N"]
    mean0, cov0 = in_tool_terms(OPS_PRIOR[A], OPS[A].context)
    information, vector = np.linalg.inv(cov0), np.linalg.inv(cov0) @ mean0
    for name, point, y in ((A, AT_A, 820.0), (B, AT_B, 350.0)):
        phi, target = _tool_feature(name, point, y)
        information = information + np.outer(phi, phi) / 0.02**2
        vector = vector + phi * target / 0.02**2
    expected_cov = np.linalg.inv(information)
    mean, cov = in_tool_terms(cone.posterior, OPS[A].context)
    assert_allclose(mean[:4], (expected_cov @ vector)[:4], rtol=0, atol=1e-9)
    assert_allclose(cov[:4, :4], expected_cov[:4, :4], rtol=1e-6, atol=1e-12)
    own = state.posterior[(A, "force_N")]
    assert cone.posterior.cov[0][0] < own.cov[0][0]  # B's reading narrowed A's cone
    assert state.posterior[(A, "force_N")] is own  # A's own belief is what its readings taught


def test_a_catalogue_start_keeps_its_operations_apart() -> None:
    """A quantity from the catalogue: each cone is the operation's own belief."""
    catalogue = start(PLAN, SETTINGS)
    state = _read(_read(catalogue, A, AT_A, 820.0), B, AT_B, 350.0)
    cone = learning.cones(state)[A]["force_N"]
    assert cone.posterior is state.posterior[(A, "force_N")]


def test_an_operation_that_has_not_read_lends_nothing() -> None:
    """Only A read: A's cone is its own belief, B's is B's prior with A's reading."""
    state = _read(STATE, A, AT_A, 820.0)
    cones = learning.cones(state)
    assert cones[A]["force_N"].posterior is state.posterior[(A, "force_N")]
    assert cones[B]["force_N"].posterior.cov[0][0] < OPS_PRIOR[B].cov[0][0]
