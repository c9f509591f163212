"""What the fleet learned of a tool's law (``rcb fleet law``, supervisor.fleet.law).

Machines read VCMR331's force and roughness on rough-grooves (test_fleet_prior's helper: a
factor of the catalogue's value at the corners of the half-size box about the centre).
"""

from __future__ import annotations

import math

import pytest
from numpy.testing import assert_allclose
from test_fleet_prior import PLAN, SETTINGS, _catalogue, _learned, _op

from models.tool import Tool
from supervisor.fleet.evidence import in_tool_terms
from supervisor.fleet.hierarchy import DEFAULT_EXPONENT_SPREAD
from supervisor.fleet.law import FleetLaw, fleet_law
from supervisor.fleet.learned import Learned
from supervisor.fleet.prior import fleet_priors, tool_beliefs
from supervisor.inputs.part_report import Measurement
from supervisor.rcb import posterior as post

TOOL: Tool = PLAN.tools[_op("rough-grooves").tool]


def _laws(learned: list[Learned]) -> dict[str, FleetLaw]:
    beliefs = tool_beliefs(TOOL, learned, 2.0, SETTINGS.exponent_sd, SETTINGS.edge_sd)
    return {q: fleet_law(b) for q, b in beliefs.items()}


def _three_machines() -> list[Learned]:
    return [
        item
        for machine, factor in (("m1", 1.10), ("m2", 1.12), ("m3", 1.08))
        for item in _learned(machine, f"p-{machine}", "rough-grooves", [factor] * 6)
    ]


def test_three_machines_10_percent_over_the_catalogue_move_K_and_keep_the_exponents() -> None:
    """Readings 1.08-1.12 x the catalogue at every corner: K is the catalogue's x 1.10 (the
    machines' mean) drawn toward the catalogue as precisions weigh (each machine says at most
    ``σ_b`` about the fleet, the catalogue ``(dK/K)/k``: hierarchy module docstring; the
    readings' own noise, 1 %, left out of the hand figure: roughness 1.094, force 1.098); the
    exponents stay the catalogue's, the feed's known better than the catalogue knew it."""
    laws = _laws(_three_machines())
    assert sorted(laws) == ["force_N", "roughness_um"]
    for quantity, law in laws.items():
        model = TOOL.models[quantity]
        assert law.catalogue_K == pytest.approx(model.K, rel=1e-12)
        machines = 3 / law.provenance.spread**2
        weight = machines / (machines + (2.0 * model.K / model.dK) ** 2)
        assert law.K / model.K == pytest.approx(1.10**weight, abs=0.005)
        assert law.K / model.K < 1.10
        exponents = {p.name: p for p in law.parameters if p.name != "edge_rise"}
        assert sorted(exponents) == sorted(_catalogue("rough-grooves", quantity).names)
        for name, p in exponents.items():
            assert p.catalogue == model.exponents[name]
            assert p.fleet == pytest.approx(p.catalogue, abs=2e-3 * abs(p.catalogue) + 1e-4)
            # a new machine's: the law's, never wider than the catalogue's, and the machines'
            # own spread of it (σ_e |e|, hierarchy), which roughness's speed exponent of 0.01,
            # that the box hardly shows, is left with
            spread = DEFAULT_EXPONENT_SPREAD * abs(p.catalogue)
            assert p.fleet_sd**2 <= p.catalogue_sd**2 + spread**2 + 1e-15
        assert exponents["feed_mm_rev"].fleet_sd < 0.5 * exponents["feed_mm_rev"].catalogue_sd
        assert law.provenance.plans == ("p-m1", "p-m2", "p-m3")
        assert law.provenance.readings == 18


def test_a_new_machine_at_the_reference_is_the_law_and_both_spreads() -> None:
    """At ``φ``, where the exponents pivot, ``φᵀDφ = σ_b²`` (hierarchy: ``φᵀL = (σ_b, 0, …)``),
    so a new machine's operation varies by ``law² + σ_b² + σ_o²``; the law is known better
    there than the catalogue, and the reference lies inside the box the machines cut in."""
    for law in _laws(_three_machines()).values():
        p = law.provenance
        assert law.new_machine_sd**2 == pytest.approx(
            law.law_sd**2 + p.spread**2 + p.operation_spread**2, rel=1e-9
        )
        assert law.law_sd < p.spread < law.catalogue_sd
        op = _op("rough-grooves")
        for name, value in law.reference.items():
            low, high = op.bounds[name]
            assert low <= value <= high, (name, value)


def test_the_law_is_the_prior_a_one_tool_plan_starts_from_on_a_new_machine() -> None:
    """``fleet_priors`` of rough-grooves (no other tool has evidence, so the spreads are the
    same) in the tool's terms is the law's ``θ``, its covariance with ``σ_o²`` on ``ln K``."""
    learned = _three_machines()
    beliefs = tool_beliefs(TOOL, learned, 2.0, SETTINGS.exponent_sd, SETTINGS.edge_sd)
    priors = fleet_priors(PLAN, learned, 2.0, SETTINGS.exponent_sd, SETTINGS.edge_sd)
    op = _op("rough-grooves")
    for quantity, belief in beliefs.items():
        made = priors[("rough-grooves", quantity)]
        mean, cov = in_tool_terms(made.posterior, op.context, SETTINGS.edge_sd)
        expected = belief.belief.cov.copy()
        expected[0, 0] += belief.provenance.operation_spread**2
        k = len(made.posterior.mean)  # rough-grooves has no edge limit: ω is the catalogue's
        assert_allclose(mean[:k], belief.belief.mean[:k], rtol=1e-9, atol=1e-12)
        assert_allclose(cov[:k, :k], expected[:k, :k], rtol=1e-7, atol=1e-14)
        assert made.provenance == belief.provenance


def test_a_steeper_feed_exponent_is_learned_where_the_catalogue_stays() -> None:
    """Three machines whose force follows feed^(e + 0.15): the fleet's feed exponent moves
    most of the way to the truth, the catalogue's column stays at e."""
    op = _op("rough-grooves")
    learned = []
    for machine in ("m1", "m2", "m3"):
        belief = _catalogue(op.name, "force_N")
        i = belief.names.index("feed_mm_rev")
        half = [0.25 * math.log(op.bounds[n][1] / op.bounds[n][0]) for n in belief.names]
        for corner in range(12):
            signs = [1 if (corner >> j) & 1 else -1 for j in range(len(half))]
            ln_x = [c + s * h for c, s, h in zip(belief.center, signs, half, strict=True)]
            point = {n: math.exp(v) for n, v in zip(belief.names, ln_x, strict=True)}
            prior = _catalogue(op.name, "force_N")
            ln_y = float(prior.features(point) @ prior.mean_array) + 0.15 * (
                ln_x[i] - prior.center[i]
            )
            y = math.exp(ln_y)
            belief = post.observe(belief, point, Measurement(y, 0.02 * y), 2.0, 0.0)
        learned.append(
            Learned(machine, f"p-{machine}", op, TOOL, belief, 2.0, SETTINGS.exponent_sd)
        )
    law = _laws(learned)["force_N"]
    feed = next(p for p in law.parameters if p.name == "feed_mm_rev")
    catalogue = TOOL.models["force_N"].exponents["feed_mm_rev"]
    assert feed.catalogue == catalogue
    assert feed.fleet - catalogue == pytest.approx(0.15, abs=0.03)
    assert feed.fleet_sd < 0.2 * feed.catalogue_sd


def test_no_evidence_of_a_tool_is_no_law() -> None:
    """Another tool's readings (CNMG432RN on rough-od) say nothing of VCMR331."""
    assert _laws(_learned("m1", "p1", "rough-od", [1.1] * 6)) == {}


def test_the_rise_over_an_edge_is_shown_where_an_operation_of_the_fleet_had_an_edge_limit() -> None:
    """rough-od's CNMG432RN has an edge limit (10 parts): its wearing force has ``ω`` after the
    exponents, at the catalogue's ``0 ± edge_sd`` beside it; rough-grooves' VCMR331 has none,
    so its ``ω`` is the catalogue's untouched and not shown."""
    tool = PLAN.tools[_op("rough-od").tool]
    learned = _learned("m1", "p1", "rough-od", [1.1] * 6) + _learned(
        "m2", "p2", "rough-od", [1.0] * 6
    )
    beliefs = tool_beliefs(tool, learned, 2.0, SETTINGS.exponent_sd, SETTINGS.edge_sd)
    force = fleet_law(beliefs["force_N"])
    names = [p.name for p in force.parameters]
    assert names == [*_catalogue("rough-od", "force_N").names, "edge_rise"]
    edge = force.parameters[-1]
    assert (edge.catalogue, edge.catalogue_sd) == (0.0, pytest.approx(SETTINGS.edge_sd))
    grooves = _laws(_three_machines())["force_N"]
    assert "edge_rise" not in [p.name for p in grooves.parameters]
