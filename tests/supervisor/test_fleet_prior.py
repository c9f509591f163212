"""The fleet prior (issue 32): evidence in the tool's terms, the hierarchy, a new plan's prior.

Numbers are worked by hand from the formulas in :mod:`supervisor.fleet.evidence` and
:mod:`supervisor.fleet.hierarchy` (cited per test).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from models.errors import InputError
from supervisor.fleet.evidence import Evidence, evidence, in_tool_terms
from supervisor.fleet.hierarchy import (
    DEFAULT_OPERATION_SPREAD,
    DEFAULT_SPREAD,
    SPREAD_WEIGHT,
    between,
    fleet_belief,
    marginal,
    of_operation,
)
from supervisor.fleet.learned import Learned
from supervisor.fleet.prior import fleet_priors
from supervisor.fleet.provenance import Provenance
from supervisor.fleet.spread import best_determined, between_estimate, operation_estimates, pooled
from supervisor.inputs.part_report import Measurement
from supervisor.inputs.plan import load_plan
from supervisor.rcb import posterior as post
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start


def between_spread(
    machines: list[Evidence], mean: np.ndarray, information: np.ndarray, reference: np.ndarray
) -> float:
    """``σ_b`` of one tool alone: the 5 % default held as 2 machines, with the estimate."""
    found = between_estimate(machines, mean, information, reference)
    return pooled(DEFAULT_SPREAD, SPREAD_WEIGHT, [found])


def operation_spread(
    machines: list[list[Evidence]], mean: np.ndarray, information: np.ndarray, exponents: int
) -> float:
    """``σ_o`` of one tool alone: the 2 % default held as 2 operations, with the estimates."""
    found = operation_estimates(machines, mean, information, exponents)
    return pooled(DEFAULT_OPERATION_SPREAD, SPREAD_WEIGHT, found)


PLAN = load_plan(Path(__file__).resolve().parents[2] / "examples" / "ivester_demo_part.toml")
SETTINGS = RcbSettings(strategy="learn")


def _catalogue(op_name: str, quantity: str) -> post.Posterior:
    op = next(o for o in PLAN.operations if o.name == op_name)
    model = PLAN.tools[op.tool].models[quantity]
    return post.prior(model, op, SETTINGS.coverage_k, SETTINGS.exponent_sd, SETTINGS.edge_sd)


def _op(name: str):  # type: ignore[no-untyped-def]
    return next(o for o in PLAN.operations if o.name == name)


def test_one_reading_at_the_centre_is_its_precision_along_1_c() -> None:
    """A reading ``y ± u`` at the box centre: ``J = (1, c)(1, c)ᵀ/σ²`` and ``h = (1, c)(ln y −
    Σ e_j ln x_j)/σ²`` with ``σ = (u/2)/y`` (evidence module docstring, ``θ = Tβ + o``)."""
    op = _op("rough-grooves")
    prior = _catalogue(op.name, "force_N")
    centre = {n: math.exp(c) for n, c in zip(prior.names, prior.center, strict=True)}
    y, u = 600.0, 12.0
    after = post.observe(prior, centre, Measurement(y, u), coverage_k=2.0, drift=0.0)
    seen = evidence(after, prior, op.context)
    sigma = (u / 2) / y
    # force wears, so θ ends with the edge's rise ω; rough-grooves has no edge limit: its
    # reading says nothing of ω (a zero row and column)
    along = np.array([1.0, *prior.center, 0.0])
    assert_allclose(seen.information, np.outer(along, along) / sigma**2, rtol=1e-6, atol=1e-3)
    context = sum(e * math.log(op.context[n]) for n, e in prior.context_exponents.items())
    assert_allclose(seen.vector, along * (math.log(y) - context) / sigma**2, rtol=1e-6)
    assert seen.readings == 1


def test_tool_terms_of_the_catalogue_prior_give_back_K_and_the_exponents() -> None:
    """The catalogue prior's mean in the tool's terms is ``(ln K, e_i, ω)`` of the tool's model,
    ``ω`` (the rise over an edge's life of rough-od's 10 parts) at 0 ± ``edge_sd``: ``n_max w``
    with ``w ~ N(0, (edge_sd / n_max)²)`` (posterior.prior)."""
    op = _op("rough-od")
    model = PLAN.tools[op.tool].models["force_N"]
    mean, cov = in_tool_terms(_catalogue(op.name, "force_N"), op.context)
    names = _catalogue(op.name, "force_N").names
    expected = [math.log(model.K), *(model.exponents[n] for n in names), 0.0]
    assert_allclose(mean, expected, rtol=1e-12, atol=1e-15)
    assert cov[-1, -1] == pytest.approx(SETTINGS.edge_sd**2, rel=1e-12)
    assert_allclose(cov[-1, :-1], 0.0, atol=1e-15)


def test_a_machine_says_at_most_the_spread_about_the_fleet() -> None:
    """One dimension: ``J' = J − J²/(σ_b⁻² + J) = 1/(1/J + σ_b²)``: 100 and 0.05 give 80."""
    one = Evidence((), np.array([[100.0]]), np.array([100.0 * 0.3]), 5)
    j, h = marginal(one, np.array([[0.05]]))
    assert_allclose(j, [[80.0]])
    assert_allclose(h, [80.0 * 0.3])
    huge = Evidence((), np.array([[1e12]]), np.array([0.0]), 10**6)
    assert_allclose(marginal(huge, np.array([[0.05]]))[0], [[1 / 0.05**2]], rtol=1e-6)


def test_a_machine_says_at_most_the_exponents_spread_about_them() -> None:
    """``J = [[100, 40], [40, 400]]``, ``h = J (0.3, 0.7)``, the exponent ``0.7 ± 2 %``
    pivoting at ``ln x = 1.5``: ``L = [[0.05, −1.5 · 0.014], [0, 0.014]]``, ``J' = (J⁻¹ +
    L Lᵀ)⁻¹`` and ``h' = J' (0.3, 0.7)`` (Woodbury; worked with the inverses). With no
    exponent spread it is the rank-one update of ``ln K`` alone: ``c = 1/(400 + 100)``,
    ``J' = J − c (100, 40)(100, 40)ᵀ``."""
    j = np.array([[100.0, 40.0], [40.0, 400.0]])
    theta = np.array([0.3, 0.7])
    one = Evidence(("feed",), j, j @ theta, 5)
    factor = between(np.array([1.0, 1.5]), 0.05, np.array([0.02 * 0.7]))
    assert_allclose(factor, [[0.05, -1.5 * 0.014], [0.0, 0.014]])
    expected = np.linalg.inv(np.linalg.inv(j) + factor @ factor.T)
    j_marginal, h_marginal = marginal(one, factor)
    assert_allclose(j_marginal, expected, rtol=1e-12)
    assert_allclose(h_marginal, expected @ theta, rtol=1e-12)
    j_lnk, _ = marginal(one, between(np.array([1.0, 1.5]), 0.05, np.array([0.0])))
    assert_allclose(j_lnk, j - np.outer([100.0, 40.0], [100.0, 40.0]) / 500.0, rtol=1e-12)


def test_a_machine_says_at_most_the_edge_spread_about_the_fleets_rise() -> None:
    """A wearing quantity's ``θ = (ln K, e, ω)``: ``L`` gains ``σ_ω`` in its last diagonal
    entry and nothing else (the rise's offset is about a new edge, ``φ``'s ``ω`` at 0). Evidence
    ``J = diag(100, 400, 1e6)`` (the rise known to 0.1 %): by hand, the rise's information
    after integrating the offset out is ``1/(1e-6 + 0.01²) = 9900.99`` (the diagonal stays
    uncoupled), so 90 parts on one machine say at most ``σ_ω`` about the fleet's rise."""
    factor = between(np.array([1.0, 1.5, 0.0]), 0.05, np.array([0.014]), 0.01)
    assert_allclose(factor, [[0.05, -1.5 * 0.014, 0.0], [0.0, 0.014, 0.0], [0.0, 0.0, 0.01]])
    j = np.diag([100.0, 400.0, 1e6])
    j_marginal, _ = marginal(Evidence(("feed",), j, np.zeros(3), 90), factor)
    assert j_marginal[2, 2] == pytest.approx(1.0 / (1e-6 + 1e-4), rel=1e-9)
    assert_allclose(j_marginal[2, :2], 0.0, atol=1e-9)


def test_an_operation_says_at_most_its_own_offset_about_its_machine() -> None:
    """``J = [[100, 40], [40, 400]]``, ``σ_o = 0.02``: integrating ``γ`` out is the rank-one
    update of ``ln K``, ``J' = J − c J e₀ e₀ᵀ J``, ``c = σ_o²/(1 + σ_o² J₀₀) = 4e-4/1.04``
    (by hand); ``h`` the same way. Two operations of one machine, each read at two feeds
    (ln feed 0 and 0.2; 1 and 1.2) on a law of slope 1, their ``ln K`` 4 % apart, the slope
    known to ±0.1 beforehand: summed as one law their difference is read as a slope of 1.038;
    each integrated over its own ``γ``, part of it is theirs and the slope moves less."""
    j = np.array([[100.0, 40.0], [40.0, 400.0]])
    one = Evidence(("feed",), j, j @ np.array([0.3, 0.7]), 5)
    c = 4e-4 / 1.04
    made = of_operation(one, 0.02)
    assert_allclose(made.information, j - c * np.outer(j[0], j[0]), rtol=1e-12)
    assert_allclose(made.vector, one.vector - c * j[0] * one.vector[0], rtol=1e-12)
    assert (made.names, made.readings) == (("feed",), 5)

    def operation(ln_feeds: tuple[float, float], ln_k: float) -> Evidence:  # 1e4 a reading
        phis = np.array([[1.0, x] for x in ln_feeds])
        ln_y = ln_k + phis[:, 1]
        information: np.ndarray = 1e4 * (phis.T @ phis)
        vector: np.ndarray = 1e4 * (phis.T @ ln_y)
        return Evidence(("feed",), information, vector, 2)

    prior = np.diag([1.0, 1 / 0.1**2])
    first, second = operation((0.0, 0.2), 0.0), operation((1.0, 1.2), 0.04)
    raw = first + second
    kept = of_operation(first, 0.02) + of_operation(second, 0.02)
    slopes = [
        np.linalg.solve(prior + e.information, prior @ [0.0, 1.0] + e.vector)[1]
        for e in (raw, kept)
    ]
    assert slopes[0] == pytest.approx(1.038, abs=1e-3)
    assert 1.0 < slopes[1] < slopes[0] - 0.005


def test_a_new_machine_varies_least_where_the_fleet_cut() -> None:
    """Two exponents known exactly at ``(0.7, 1.0)``, ``ln K`` too: a new machine's ``ln Y``
    varies about the reference ``x_r = (1, 2)`` by ``σ_b² + Σ (σ_e e_i (x_i − x_ri))²``, at
    the reference by ``σ_b²`` alone, wherever it lies."""
    mean = np.array([0.0, 0.7, 1.0])
    exact = np.diag([1e-14] * 3)
    reference = np.array([1.0, 1.0, 2.0])
    belief = fleet_belief([], mean, exact, reference, 2, 0.05, exponent_spread=0.02)
    for x in ([1.0, 2.0], [0.0, 0.0], [1.5, 2.5]):
        phi = np.array([1.0, *x])
        spread = 0.05**2 + sum(
            (0.02 * e * (xi - r)) ** 2 for e, xi, r in zip(mean[1:], x, reference[1:], strict=True)
        )
        assert phi @ belief.cov @ phi == pytest.approx(spread, rel=1e-6)


def test_the_spread_pools_the_default_with_DerSimonian_Laird() -> None:
    """Two machines at ``ln Y`` 0 and 0.1, variance 1e-4 each, a flat prior: ``Q = 50``,
    ``τ̂² = (50 − 1)/10 000 = 0.0049``; ``σ_b² = (2 · 0.05² + 1 · 0.0049)/3``."""
    flat = np.array([[1e-12]])
    machines = [Evidence((), np.array([[1e4]]), np.array([1e4 * y]), 30) for y in (0.0, 0.1)]
    spread = between_spread(machines, np.array([0.0]), flat, np.array([1.0]))
    assert spread == pytest.approx(math.sqrt((2 * 0.05**2 + 0.0049) / 3), rel=1e-6)
    same = [Evidence((), np.array([[1e4]]), np.array([0.0]), 30) for _ in range(2)]
    assert between_spread(same, np.array([0.0]), flat, np.array([1.0])) == pytest.approx(
        math.sqrt(2 * 0.05**2 / 3)
    )
    assert between_spread(machines[:1], np.array([0.0]), flat, np.array([1.0])) == 0.05


def test_the_operations_spread_pools_the_default_with_each_machines_operations() -> None:
    """Machine A's two operations at ``ln Y`` 0 and 0.1 (variance 1e-4 each, a flat prior):
    ``τ̂² = 0.0049`` on 1 degree of freedom (the worked case above); machine B's two at 0 and
    0: ``τ̂² = 0``, 1 more; machine C's one operation says nothing of the spread. ``σ_o² =
    (2 · 0.02² + 0.0049 + 0)/(2 + 2)`` (spread.operation_estimates, pooled): 3.77 %, where
    the fixed 2 % had held it."""
    flat = np.array([[1e-12]])

    def at(y: float) -> Evidence:
        return Evidence((), np.array([[1e4]]), np.array([1e4 * y]), 30)

    machines = [[at(0.0), at(0.1)], [at(0.0), at(0.0)], [at(0.3)]]
    spread = operation_spread(machines, np.array([0.0]), flat, 0)
    assert spread == pytest.approx(math.sqrt((2 * 0.02**2 + 0.0049) / 4), rel=1e-6)
    assert spread == pytest.approx(0.0377, abs=1e-4)
    assert operation_spread([[at(0.0)], [at(0.5)]], np.array([0.0]), flat, 0) == 0.02


def test_machines_are_compared_where_their_readings_pin_ln_Y() -> None:
    """Two machines, each two readings at ``ln x = 2 ± 0.1`` (σ² = 2e-4), one at ``ln y`` 0,
    one at 0.1, a nearly flat prior: the best-known point is ``ln x = 2`` (the readings'
    mean), where each ``ln Y`` is known to ``σ²/2 = 1e-4`` and the spread is the worked
    ``(2 · 0.05² + 0.0049)/3`` above. At ``ln x = 0`` each is only known to ``σ² (1/2 +
    2²/0.02) = 0.0401``: ``Q = 0.125 < 1``, ``τ̂ = 0``, the default's floor ``(2 · 0.05²)/3``."""
    sigma2 = 2e-4
    machines = []
    for level in (0.0, 0.1):
        points = [np.array([1.0, 2.0 - 0.1]), np.array([1.0, 2.0 + 0.1])]
        j = sum(np.outer(p, p) for p in points) / sigma2
        h = sum(p * level for p in points) / sigma2
        machines.append(Evidence(("feed",), j, h, 2))
    flat = np.eye(2) * 1e-9
    best = best_determined(machines, flat, 1, (0.0,))
    assert_allclose(best, [1.0, 2.0], atol=1e-6)
    at_best = between_spread(machines, np.zeros(2), flat, best)
    assert at_best == pytest.approx(math.sqrt((2 * 0.05**2 + 0.0049) / 3), rel=1e-4)
    at_zero = between_spread(machines, np.zeros(2), flat, np.array([1.0, 0.0]))
    assert at_zero == pytest.approx(math.sqrt(2 * 0.05**2 / 3), rel=1e-9)


def test_a_new_machine_is_the_fleet_mean_plus_the_spread() -> None:
    """Prior ``N(0, 1)``, one machine ``J = 100, h = 100 · 0.2``: ``J' = 80, h' = 16``,
    ``P = 81``, mean ``16/81``, variance ``1/81 + 0.05²`` (hierarchy module docstring)."""
    one = Evidence((), np.array([[100.0]]), np.array([20.0]), 7)
    belief = fleet_belief([one], np.array([0.0]), np.array([[1.0]]), np.array([1.0]), 0, 0.05)
    assert_allclose(belief.mean, [16 / 81])
    assert_allclose(belief.cov, [[1 / 81 + 0.05**2]])
    assert (belief.machines, belief.readings, belief.spread) == (1, 7, 0.05)


def _learned(machine: str, plan: str, op_name: str, readings: list[float]) -> list[Learned]:
    """``op_name``'s force and roughness posteriors after readings of ``factor`` x the
    catalogue's value at the corners of the half-size box about its centre, in turn."""
    op = _op(op_name)
    out = []
    for quantity in ("force_N", "roughness_um"):
        belief = _catalogue(op_name, quantity)
        half = [0.25 * math.log(op.bounds[n][1] / op.bounds[n][0]) for n in belief.names]
        for i, factor in enumerate(readings):
            signs = [1 if (i >> j) & 1 else -1 for j in range(len(half))]
            ln_x = [c + s * h for c, s, h in zip(belief.center, signs, half, strict=True)]
            point = {n: math.exp(v) for n, v in zip(belief.names, ln_x, strict=True)}
            prior = _catalogue(op_name, quantity)
            y = factor * math.exp(float(prior.features(point) @ prior.mean_array))
            belief = post.observe(belief, point, Measurement(y, 0.02 * y), 2.0, 0.0)
        out.append(
            Learned(machine, plan, op, PLAN.tools[op.tool], belief, 2.0, SETTINGS.exponent_sd)
        )
    return out


def test_a_new_plan_starts_from_what_two_machines_learned() -> None:
    """Both machines read 10 % over the catalogue: the prior's mean follows, its band narrows to
    little more than the between-machine spread,
    the other operation of the same tool (VCMR331) gets it too, and the provenance says so."""
    learned = _learned("m1", "p1", "rough-grooves", [1.1] * 6)
    learned += _learned("m2", "p2", "rough-grooves", [1.1] * 6)
    priors = fleet_priors(PLAN, learned, 2.0, SETTINGS.exponent_sd)
    catalogue = _catalogue("rough-contour", "force_N")
    made = priors[("rough-contour", "force_N")]
    assert made.posterior.mean[0] == pytest.approx(catalogue.mean[0] + math.log(1.1), abs=0.02)
    assert made.provenance.spread**2 < made.posterior.cov[0][0] < 0.2 * catalogue.cov[0][0]
    assert ("rough-od", "force_N") not in priors  # another tool (CNMG432RN): no evidence
    assert made.provenance == Provenance(
        "force_N", ("p1", "p2"), ("m1", "m2"), made.provenance.spread, 12, 0.02
    )  # each machine ran VCMR331 in one operation: the operations' spread is the default's
    assert made.provenance.describe() == (
        "force_N: prior from 2 plans on 2 machines, between-machine spread "
        f"{100 * made.provenance.spread:.1f} %, between operations 2.0 %, 12 readings"
    )


def test_a_prior_that_knows_an_exponent_exactly_keeps_the_catalogue() -> None:
    """exponent_sd = 0 (a setting the REST service takes) makes the catalogue prior singular:
    no fleet prior can be formed in information form, so none is made (the catalogue's stands,
    no error); learned evidence with such a prior is left out the same way. Found by the REST
    schema fuzzing (POST /plans?exponent_sd=0.0 answered 500 once the fleet held evidence)."""
    learned = _learned("m1", "p1", "rough-grooves", [1.1] * 6)
    learned += _learned("m2", "p2", "rough-grooves", [1.1] * 6)
    assert ("rough-contour", "force_N") in fleet_priors(PLAN, learned, 2.0, SETTINGS.exponent_sd)
    assert fleet_priors(PLAN, learned, 2.0, 0.0) == {}
    exact = [replace(item, exponent_sd=0.0) for item in learned]
    assert fleet_priors(PLAN, exact, 2.0, SETTINGS.exponent_sd) == {}
    # rough-grooves has no edge-life limit, so no wear term: edge_sd = 0 changes nothing there
    assert fleet_priors(PLAN, learned, 2.0, SETTINGS.exponent_sd, edge_sd=0.0).keys() == {
        ("rough-grooves", "force_N"),
        ("rough-grooves", "roughness_um"),
        ("rough-contour", "force_N"),
        ("rough-contour", "roughness_um"),
    }


def test_on_a_machine_of_the_fleet_its_own_readings_count_in_full() -> None:
    """The plan's own machine: its offset is known from its readings, so the prior is
    narrower than a new machine's (which adds the whole spread)."""
    learned = _learned("lathe-22kW", "p1", "rough-grooves", [1.1] * 6)
    learned += _learned("m2", "p2", "rough-grooves", [1.1] * 6)
    own = fleet_priors(PLAN, learned, 2.0, SETTINGS.exponent_sd)[("rough-grooves", "force_N")]
    other = [replace(i, machine="m3") if i.machine == "lathe-22kW" else i for i in learned]
    new = fleet_priors(PLAN, other, 2.0, SETTINGS.exponent_sd)[("rough-grooves", "force_N")]
    assert own.posterior.cov[0][0] < 0.5 * new.posterior.cov[0][0]


def test_a_fleet_prior_starts_faster_than_the_catalogue() -> None:
    """Two machines that read the catalogue's value and a between-machine spread of 2 %: the
    first setpoints run faster (at the default 5 % the cone, ``4 σ`` wide, is no narrower than
    the catalogue's roughness bands of these tools)."""
    learned: list[Learned] = []
    for name in ("rough-od", "rough-grooves", "rough-contour", "finish-od"):
        learned += _learned("m1", "p1", name, [1.0] * 16) + _learned("m2", "p2", name, [1.0] * 16)
    priors = fleet_priors(PLAN, learned, 2.0, SETTINGS.exponent_sd, default_spread=0.02)
    fleet = start(PLAN, SETTINGS, {k: p.posterior for k, p in priors.items()})
    catalogue = start(PLAN, SETTINGS)
    assert fleet.setpoints.cycle_time_min < 0.97 * catalogue.setpoints.cycle_time_min
    assert fleet.priors == fleet.posterior


def test_only_learn_starts_from_a_fleet_prior() -> None:
    prior = {("rough-od", "force_N"): _catalogue("rough-od", "force_N")}
    with pytest.raises(InputError) as caught:
        start(PLAN, RcbSettings(strategy="ivester"), prior)
    assert caught.value.field == "prior"
    with pytest.raises(InputError, match="not .operation, quantity. pairs"):
        start(PLAN, SETTINGS, {("nowhere", "force_N"): prior[("rough-od", "force_N")]})


def test_a_tools_spread_starts_from_the_plans_other_tools() -> None:
    """Two machines that read the catalogue's value with every tool of four operations: each
    of the 6 tool-quantity pairs (CNMG432RN, VCMR331, CPGM32505 x force, roughness) shows a
    DerSimonian-Laird spread of 0 on 1 degree of freedom, so each one's default is the 5 %
    pooled with the 5 others': ``σ_b = 0.05 √(2/7)`` = 2.7 % (each tool alone: ``0.05 √(2/3)``
    = 4.1 %, the floor of 2 agreeing machines before). A pair learned alone keeps that rule;
    a tool whose machines differ by 20 % (ln: 0.18, ``τ̂²`` about 0.0166 on 1 degree of
    freedom, roughness too) is pooled to 8 %, over the others', which its estimates raise
    over the 5 % default (7.2 %)."""
    learned: list[Learned] = []
    for name in ("rough-od", "rough-grooves", "rough-contour", "finish-od"):
        learned += _learned("m1", "p1", name, [1.0] * 16) + _learned("m2", "p2", name, [1.0] * 16)
    priors = fleet_priors(PLAN, learned, 2.0, SETTINGS.exponent_sd)
    assert len({(PLAN.tools[_op(op).tool].name, q) for op, q in priors}) == 6
    for made in priors.values():
        assert made.provenance.spread == pytest.approx(0.05 * math.sqrt(2 / 7), rel=1e-6)
    alone = [item for item in learned if item.posterior.quantity == "force_N"]
    alone = [item for item in alone if item.operation.name == "rough-od"]
    made = fleet_priors(PLAN, alone, 2.0, SETTINGS.exponent_sd)[("rough-od", "force_N")]
    assert made.provenance.spread == pytest.approx(0.05 * math.sqrt(2 / 3), rel=1e-6)
    apart = [
        item
        for item in learned
        if not (item.machine == "m2" and item.operation.name == "finish-od")
    ]
    apart += _learned("m2", "p2", "finish-od", [1.2] * 16)
    priors = fleet_priors(PLAN, apart, 2.0, SETTINGS.exponent_sd)
    spreads = {key: p.provenance.spread for key, p in priors.items()}
    assert spreads[("finish-od", "force_N")] > 0.08
    others = [s for (op, _), s in spreads.items() if op != "finish-od"]
    assert all(0.05 < s < spreads[("finish-od", "force_N")] for s in others)
