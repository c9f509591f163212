"""The fleet's noise prior and its check (issue 32: :mod:`supervisor.fleet.noise`,
:mod:`supervisor.rcb.noise_check`).

The evidence of the inverse-gamma prior is checked against numerical integration; the prior
against hand-made chains; the learner against a new machine whose instruments are 3 x noisier
than the fleet's (the prior is let go at its first part and no limit is crossed after it) and
one whose are the fleet's kind (kept, and its readings then count for more).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, special

from supervisor.fleet.learned import Learned
from supervisor.fleet.noise import DEFAULT_CHAIN_SPREAD, MIN_READINGS, noise_priors
from supervisor.inputs.plan import load_plan
from supervisor.rcb import posterior as post
from supervisor.rcb.judged import Judged
from supervisor.rcb.monitor_state import Monitor
from supervisor.rcb.noise import NoiseScale, pooled
from supervisor.rcb.noise_check import (
    IN_FORCE_READINGS,
    Innovation,
    in_force,
    kept,
    log_evidence,
    log_marginal,
    rejects,
)
from supervisor.virtual.fault_spec import parse_faults
from supervisor.virtual.fleet_scenario import run_fleet_scenario

PLAN = load_plan(Path(__file__).resolve().parents[2] / "examples" / "ivester_demo_part.toml")


def _evidence(readings: float, noise: float) -> NoiseScale:
    """A chain's evidence of ``readings`` readings whose mean excess square is ``noise``."""
    return NoiseScale.of_evidence(readings, readings * noise)


def _learned(machine: str, readings: float, noise: float, quantity: str = "force_N") -> Learned:
    op = PLAN.operations[0]
    tool = PLAN.tools[op.tool]
    belief = post.prior(tool.models[quantity], op, 2.0, 0.05)
    return Learned(machine, f"plan-{machine}", op, tool, belief, 2.0, 0.05,
                   chain=_evidence(readings, noise))  # fmt: skip


@given(st.floats(1.5, 40.0), st.floats(0.5, 40.0), st.integers(1, 30), st.floats(0.1, 50.0))
@settings(max_examples=40, deadline=None)
def test_the_evidence_is_the_integral_over_the_noise_scale(
    shape: float, rate: float, readings: int, excess: float
) -> None:
    """``∫ λ^{-n/2} e^{-S/2λ} InvGamma(λ; a, b) dλ`` (Gelman et al. §2.6), integrated."""

    def integrand(lam: float) -> float:
        log_ig = shape * math.log(rate) - math.lgamma(shape) - (shape + 1) * math.log(lam)
        return math.exp(log_ig - rate / lam - readings / 2 * math.log(lam) - excess / (2 * lam))

    value, _ = integrate.quad(integrand, 0.0, math.inf, limit=400, epsabs=0.0, epsrel=1e-11)
    assert log_evidence(NoiseScale(shape, rate), readings, excess) == pytest.approx(
        math.log(value), abs=1e-6
    )


def test_a_chain_unlike_the_fleets_lets_its_noise_prior_go_and_one_like_them_keeps_it() -> None:
    fleet = NoiseScale(18.0, 17.0)  # λ̄ 1, spread 25 %
    # one part of six operations, 3 x noisier than reported: λ = 9
    assert rejects(fleet, _evidence(6, 9.0), [])
    assert not rejects(fleet, _evidence(6, 1.0), [])  # as the fleet's
    assert not rejects(fleet, NoiseScale(), [])  # no reading yet
    # quieter than the fleet's prior says, by enough: let go too (ln B 6.05; λ 0.5: 1.22)
    assert rejects(fleet, _evidence(60, 0.3), [])
    assert not rejects(fleet, _evidence(60, 0.5), [])
    # a fleet whose instruments were 3 x noisier than they claimed (λ̄ 9) and an honest chain:
    # one part of six operations cannot tell (ln B 1.44 at 3 readings), two can (6.07 at 12);
    # kept, the fleet's prior would count its readings at 9 x their variance for good
    noisy = NoiseScale(18.0, 9 * 17.0)
    assert not rejects(noisy, _evidence(3, 1.0), [])
    assert rejects(noisy, _evidence(12, 1.0), [])
    assert not rejects(noisy, _evidence(60, 9.0), [])  # the fleet's kind
    # 1.7 x noisier (λ 3): one part's readings cannot tell, ten parts' can; 1.5 x (λ 2.25)
    # not even thirty's against a default this vague (ln B 2.67 < ln 19): the chain's own
    # readings then outweigh the fleet's prior by five to one (pooled: λ̂ 2.0)
    assert not rejects(fleet, _evidence(6, 3.0), [])
    assert rejects(fleet, _evidence(60, 3.0), [])
    assert not rejects(fleet, _evidence(180, 2.25), [])
    assert pooled([_evidence(180, 2.25)], fleet).scale ** 2 == pytest.approx(
        (17 + 202.5) / (18 + 90), rel=1e-12
    )


def _innovations(model: float, lam: float, n: int = 6, noise: float = 1e-4) -> list[Innovation]:
    """``n`` innovations of a chain with noise scale ``lam``, at ``±1`` of their sd."""
    sd = math.sqrt(model + lam * noise)
    return [Innovation((-1) ** i * sd, model, noise) for i in range(n)]


def test_the_marginal_is_the_conjugate_one_when_the_model_is_known_and_a_part_can_tell() -> None:
    """With ``m_i = 0`` the grid gives the closed form (less the readings' ``2π u`` terms); a
    first part, whose innovations are the machine's offset (``m`` 30 x the noise), cannot tell
    a chain 3 x noisier; a later part (``m`` a tenth of it) can."""
    fleet = NoiseScale(18.0, 17.0)
    items = _innovations(0.0, 4.0)
    constant = -0.5 * sum(math.log(2 * math.pi * i.noise) for i in items)
    excess = sum(i.e**2 / i.noise for i in items)
    for prior in (fleet, NoiseScale()):
        assert log_marginal(prior, NoiseScale(), items) == pytest.approx(
            constant + log_evidence(prior, len(items), excess), abs=1e-6
        )
    assert not rejects(fleet, NoiseScale(), _innovations(3e-3, 9.0))
    assert rejects(fleet, NoiseScale(), _innovations(1e-5, 9.0))
    assert not rejects(fleet, NoiseScale(), _innovations(1e-5, 1.0))
    judged: list[Judged] = []
    for noise, left in ((9.0, {}), (1.0, {"force_N": fleet})):
        chain = _evidence(60, noise)
        monitors = {
            ("rough-od", "force_N"): Monitor(chain_shape=chain.shape, chain_rate=chain.rate)
        }
        assert kept({"force_N": fleet}, monitors, judged) == left


def test_the_fleets_noise_prior_is_in_force_once_the_chain_can_tell_its_noise() -> None:
    """Its own readings worth :data:`IN_FORCE_READINGS` of pure noise, over its operations."""
    fleet = NoiseScale(18.0, 17.0)
    half = IN_FORCE_READINGS / 2
    assert in_force(fleet, [_evidence(half - 0.01, 1.0), _evidence(half, 1.0)]) is None
    assert in_force(fleet, [_evidence(half, 1.0), _evidence(half, 1.0)]) == fleet
    assert in_force(None, [_evidence(60, 1.0)]) is None


def test_pooled_starts_from_the_chains_prior_where_it_is_the_fleets() -> None:
    fleet = NoiseScale(18.0, 17.0)
    one, two = _evidence(6, 1.0), _evidence(12, 2.0)
    both = pooled([one, two], fleet)
    assert (both.shape, both.rate) == pytest.approx((18.0 + 9.0, 17.0 + 3.0 + 12.0), rel=1e-12)
    assert pooled([one, two]) == pooled([one, two], NoiseScale())


def test_the_prior_of_three_honest_chains_and_of_one() -> None:
    three = noise_priors([_learned(f"m{i}", 180, 1.0) for i in range(3)])["force_N"]
    # three chains that agree: the default spread held as 2 machines, pooled with τ̂² = 0
    assert three.spread == pytest.approx(DEFAULT_CHAIN_SPREAD / math.sqrt(2), rel=1e-9)
    # each chain's belief InvGamma(1.5 + 90, 1 + 90): E ln λ = ln 91 − ψ(91.5), Var = ψ′(91.5)
    mean_ln, var_ln = math.log(91.0) - special.digamma(91.5), special.polygamma(1, 91.5)
    assert var_ln == pytest.approx(2 / 180, rel=0.02)  # the χ²-log variance of many readings
    total = three.spread**2 + 1 / (3 / (var_ln + three.spread**2))
    assert three.belief.shape == pytest.approx(2 + 1 / math.expm1(total), rel=1e-9)
    assert three.scale**2 == pytest.approx(math.exp(mean_ln + 0.5 * total), rel=1e-9)
    assert (three.machines, three.readings) == (("m0", "m1", "m2"), 540)
    assert three.describe() == (
        f"force_N noise: {three.scale:.2f} x the reported u from 540 readings' worth on 3 "
        "machines, between-chain spread 21 %"
    )
    one = noise_priors([_learned("m0", 180, 1.0)])["force_N"]
    assert one.spread == DEFAULT_CHAIN_SPREAD
    assert one.belief.shape < three.belief.shape  # one machine says less than three
    # the first 93 % quantile the chain is counted at: the default's 4.46, the fleet's under 1.5
    assert NoiseScale().prudent_scale ** 2 == pytest.approx(4.457, abs=1e-3)
    assert pooled([], three.belief).prudent_scale ** 2 < 1.5


def test_chains_that_disagree_widen_and_quiet_or_thin_ones_do_not_lower_the_floor() -> None:
    apart = noise_priors([_learned("m0", 180, 1.0), _learned("m1", 180, 4.0)])["force_N"]
    assert apart.spread > DEFAULT_CHAIN_SPREAD
    quiet = noise_priors([_learned(f"m{i}", 180, 0.2) for i in range(3)])["force_N"]
    assert quiet.scale == pytest.approx(1.0)  # a chain quieter than it claims is not trusted
    thin = [_learned("m0", MIN_READINGS - 1, 1.0)]
    assert noise_priors(thin) == {}
    assert noise_priors([replace(_learned("m0", 180, 1.0), chain=None)]) == {}  # none known


def test_chains_whose_innovations_all_lay_within_the_model_compare_by_their_beliefs() -> None:
    """Two virtual lathes' spindle loads (``docs/try-a-machine.md``, seeds 7 and 9, 10 parts
    each): ``u`` is mostly the calibration's, so every innovation lay within the model's
    uncertainty and one chain's excess squares are exactly 0. Compared through ``ln(S/n)``
    with a floor of ``10⁻⁶`` they were 361 % apart; their beliefs are 7 % apart."""
    quiet = [_learned("lathe-b", 21.68, 0.0), _learned("lathe-22kW", 21.65, 0.149 / 21.65)]
    prior = noise_priors(quiet)["force_N"]
    # ln(1.0745 / 1.0) − (ψ(12.325) − ψ(12.34)) apart, each ψ′ ≈ 0.085: Q 0.03 < 1, τ̂² = 0
    assert prior.spread == pytest.approx(DEFAULT_CHAIN_SPREAD * math.sqrt(2 / 3), rel=1e-12)
    assert prior.scale == 1.0  # quieter than reported: not trusted to be
    assert prior.describe().endswith("on 2 machines, between-chain spread 24 %")
    # a quiet chain beside an honest one does differ, by what the two beliefs say (DL by hand)
    honest = _learned("lathe-c", 21.68, 1.0)
    apart = noise_priors([quiet[0], honest])["force_N"]
    a = 1.5 + 21.68 / 2
    d, v = math.log(1.0 + 21.68 / 2), special.polygamma(1, a)
    tau2 = d * d / 2 - v
    assert apart.spread == pytest.approx(
        math.sqrt((2 * DEFAULT_CHAIN_SPREAD**2 + tau2) / 3), rel=1e-9
    )
    assert 1.0 < apart.spread < 2.0


@given(st.lists(st.tuples(st.floats(6.0, 1000.0), st.floats(0.05, 20.0)), min_size=1, max_size=6))
@settings(max_examples=60, deadline=None)
def test_a_fleets_noise_prior_is_proper_and_never_quieter_than_reported(
    chains: list[tuple[float, float]],
) -> None:
    prior = noise_priors([_learned(f"m{i}", n, s) for i, (n, s) in enumerate(chains)])["force_N"]
    assert prior.belief.shape > 2.0  # a finite variance: a coefficient of variation
    assert prior.scale >= 1.0 - 1e-12
    assert prior.spread >= DEFAULT_CHAIN_SPREAD * math.sqrt(2 / (2 + len(chains) - 1)) - 1e-12


@pytest.mark.parametrize("fault", ["noise-scale:3", ""])
def test_a_new_machine_whose_instruments_are_not_the_fleets_lets_the_noise_prior_go(
    fault: str,
) -> None:
    """``closed_loop.py --fleet 4 --fault noise-scale:3``, seed 3: without the check, the new
    machine's cone narrowed on readings counted 9 x too precise and crossed limits from part 2."""
    faults = parse_faults([fault] if fault else [])
    trace = run_fleet_scenario(PLAN, 3, 4, parts=6, learn_parts=10, faults=faults)
    assert trace.noise_let_go == (2 if fault else 0)
    assert [p for p, _, _ in trace.fleet.where if p > 1] == []
