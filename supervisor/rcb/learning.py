r"""The ``learn`` strategy's hooks: what it expects of a reading, what it learns, its cones.

Per operation and quantity ``learn`` keeps a posterior of the whole power law
(:mod:`supervisor.rcb.posterior`) beside the band law's fallback band. For each reading that
:func:`supervisor.rcb.monitor.watch` lets through:

1. a change (or a confirmed quarantine) first discounts the old regime: the intercept's
   variance grows by the ``q`` the monitor sized to explain the innovation;
2. a confirmed quarantined reading is learned, then the reading itself, each with the noise at
   the monitor's measured scale ``ŝ`` (``u`` becomes ``ŝ u``); a reading past the band that
   is no change, its innovation ``e`` beyond its spread ``v`` (the monitor's), first widens
   the intercept's variance by ``q = e² − v``, the change's moment matching below the change's
   threshold [3]_: the prior held ``ln K`` too tightly for this machine, and the update would
   put the surprise where the prior is loosest, in an exponent at the box's edge (a machine
   1.59x the catalogue's force, read at depth's edge, taught a depth exponent of 1.44 for
   0.98 and crossed after a step: docs/benchmarks.md, *A surprise at the box's edge*). The
   widening is the start's (``prior_widening``), the prior the readings are counted against.
   Only a catalogue start: a fleet prior's widening is :mod:`.prior_check`'s, whose Bayes
   factor lets it go, for good and on every surface, at 19 to 1 odds, not on one surprise;
3. *evidence against the model wins at once*: after a reading past the band (``above_band``,
   ``breach``) or a change, the posterior mean at the setpoint that made it is at least
   ``ln(y − ŝ u)``, the reading less its scatter as measured; where the update left it under
   that (a posterior that many earlier readings hold in place), its intercept is raised to it
   by ``d`` and its variance grows by ``d²``: the raise is a level the readings so far did not
   show, held with its own uncertainty. The raise moves every prediction up by the same
   factor and widens the cone: it only ever makes the cone more cautious. Held at the earlier
   readings' full weight (the mean moved, the precision kept), it would read as if every
   earlier reading had been ``d`` higher, and the next readings, at a setpoint the raise
   itself moved, would teach a slope the truth does not have (a feed exponent of 1.07 learned
   as 1.44 over 150 parts: docs/benchmarks.md, *A year of parts*).

References
----------
.. [1] Bishop, Pattern Recognition and Machine Learning (2006), §3.3 (sequential Bayesian
   linear regression).
.. [2] Ivester & Heigel (NIST), "Adaptive Control Optimization": the bands "encompass all of
   the points" (the reading a band must cover).
.. [3] Jazwinski (1969), "Adaptive filtering", Automatica 5(4), 475-485 (the process noise
   that explains an innovation's excess over its predicted variance).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from supervisor.inputs.part_report import COVERAGE_FACTOR, Measurement
from supervisor.inputs.plan import Operation
from supervisor.optimize.result import OperationResult
from supervisor.rcb import information
from supervisor.rcb import posterior as post
from supervisor.rcb.beliefs import Beliefs
from supervisor.rcb.cone import Cone
from supervisor.rcb.decision import Action, Decision
from supervisor.rcb.monitor import Watched
from supervisor.rcb.monitor_state import Expected, Reading
from supervisor.rcb.noise import NoiseScale
from supervisor.rcb.posterior import Posterior


def belief_of(state: Beliefs, operation: Operation, quantity: str) -> Posterior:
    """The posterior in force for ``operation``'s ``quantity`` (the catalogue prior if none)."""
    found = state.posterior.get((operation.name, quantity))
    return _prior_of(state, operation, quantity) if found is None else found


def _prior_of(state: Beliefs, operation: Operation, quantity: str) -> Posterior:
    """The prior of ``operation``'s ``quantity``: the plan's start (a fleet's) or the catalogue.

    A start its readings rejected is read widened (``prior_widening``: a fleet prior by
    :mod:`supervisor.rcb.prior_check`, any start by a surprise, module docstring 2).
    """
    started = state.priors.get((operation.name, quantity))
    belief = state.posterior.get((operation.name, quantity))
    if started is not None:
        return as_started(started, belief)
    settings = state.settings
    key = (operation.name, quantity, settings.coverage_k, settings.exponent_sd, settings.edge_sd)
    # kept on the (immutable) plan: a part asks for it at every reading and re-check
    cache: dict[tuple[object, ...], tuple[Operation, Posterior]]
    cache = state.plan.__dict__.setdefault("_catalogue_priors", {})
    kept = cache.get(key)
    if kept is None or not (kept[0] is operation or kept[0] == operation):
        model = state.plan.tools[operation.tool].models[quantity]
        made = post.prior(
            model, operation, settings.coverage_k, settings.exponent_sd, settings.edge_sd
        )
        kept = cache[key] = (operation, made)
    return as_started(kept[1], belief)


def expects(
    state: Beliefs,
    operation: Operation,
    result: OperationResult,
    quantity: str,
    age: int | None,
    chain: NoiseScale | None = None,
) -> Expected:
    """The posterior predictive of ``ln y`` at ``result``'s setpoint (without the noise).

    ``chain``: the measuring chain's noise scale; the spread with the readings counted at its
    estimate ``ŝ²`` (not the prudent quantile they are learned at) is what the noise update
    takes out of an innovation: the prudent one, larger, would teach a noise scale too low.
    """
    belief = belief_of(state, operation, quantity)
    point = {**result.setpoint, **operation.context}
    cone = Cone(belief, state.settings.z, state.settings.tau)
    n = belief.edge_age(age)
    mean = float(belief.features(point, n) @ belief.mean_array)
    rel = operation.setpoint_rel_uncertainty
    spread = cone.spread(point, rel, n)
    estimate = None
    if chain is not None and chain.scale**2 < belief.noise_scale2:
        prior_belief = _prior_of(state, operation, quantity)
        at_estimate = rescaled(belief, prior_belief, chain.scale**2)
        estimate = Cone(at_estimate, state.settings.z, state.settings.tau).spread(point, rel, n)
    return Expected(mean, spread, estimate_sd=estimate)


def learn(
    state: Beliefs,
    operation: Operation,
    result: OperationResult,
    law: Decision,
    measurement: Measurement,
    watched: Watched,
    age: int | None,
) -> tuple[Posterior, Decision]:
    """The posterior after the reading (module docstring) and the decision that shows it.

    ``measurement``: the reading with its ``u`` at the measured scale.
    """
    settings = state.settings
    before = belief_of(state, operation, law.quantity)
    after = before
    scale = measurement.uncertainty / law.uncertainty if law.uncertainty > 0 else 1.0
    if scale**2 != before.noise_scale2:  # the chain's noise, as now believed, has moved
        after = rescaled(after, _prior_of(state, operation, law.quantity), scale**2)
    if watched.forget > 0:
        after = discount(after, watched.forget)
    if watched.shift:
        after = shifted(after, watched.shift)
    point = {**result.setpoint, **operation.context}
    if watched.held is not None:  # the quarantined reading its successor confirmed
        held = _held_measurement(watched.held, scale)
        after = post.observe(
            after, _held_point(watched.held), held, settings.coverage_k, settings.tau, age
        )
    if measurement.value > 0 and measurement.uncertainty > 0:
        if law.flagged and not watched.changed:
            after = _surprised(state, operation, law.quantity, after, watched)
        after = post.observe(after, point, measurement, settings.coverage_k, settings.tau, age)
        if law.flagged or watched.changed:
            after = _at_least(after, point, measurement, age)
    return after, _decision(state, operation, result, law, before, after)


def settled(state: Beliefs, chains: Mapping[str, NoiseScale]) -> dict[tuple[str, str], Posterior]:
    """The posteriors whose readings the report's end counts at another noise scale.

    Each reading is learned at the chain's prudent scale as it stood with the readings of the
    report before it (:func:`supervisor.rcb.update._reading`): the first operations of a report
    would make the next part at a scale that the rest of the report has already shown to be
    too low (a chain 3x noisier than it claims: its first report raises the prudent scale from
    2.11 to about 3.5). Once every reading is in, each posterior is :func:`rescaled` to its
    chain's :attr:`~supervisor.rcb.noise.NoiseScale.prudent_scale`, as its next reading would
    do anyway; the setpoints of the next part then rest on all the report shows.
    """
    operations = {op.name: op for op in state.plan.operations}
    out: dict[tuple[str, str], Posterior] = {}
    for (name, quantity), belief in state.posterior.items():
        chain = chains.get(quantity)
        if chain is None:
            continue
        scale2 = chain.prudent_scale**2
        if scale2 != belief.noise_scale2:
            prior_belief = _prior_of(state, operations[name], quantity)
            out[(name, quantity)] = rescaled(belief, prior_belief, scale2)
    return out


def cones(state: Beliefs) -> dict[str, dict[str, Cone]]:
    """The cone constraints of a ``learn`` state, per operation and quantity.

    Each vetoes the band optimum at its start prior's ``band_veto_z`` (a fleet's whose machines
    differ by more than the band; never above the plan's ``z``), else at its mean.
    """
    out: dict[str, dict[str, Cone]] = {}
    z, tau = state.settings.z, state.settings.tau
    for key, belief in state.posterior.items():
        started = state.priors.get(key)
        veto_z = 0.0 if started is None else min(started.band_veto_z, z)
        out.setdefault(key[0], {})[key[1]] = Cone(belief, z, tau, veto_z)
    return out


def _surprised(
    state: Beliefs, operation: Operation, quantity: str, belief: Posterior, watched: Watched
) -> Posterior:
    """``belief`` with its start widened by a flagged reading's surprise (module docstring, 2)."""
    if watched.innovation is None or (operation.name, quantity) in state.priors:
        return belief
    e, spread2 = watched.innovation
    excess = e * e - spread2
    if excess <= 0:
        return belief
    return replace(discount(belief, excess), prior_widening=belief.prior_widening + excess)


def _held_point(held: Reading) -> dict[str, float]:
    return {name: math.exp(v) for name, v in held.ln_x.items()}


def _held_measurement(held: Reading, scale: float) -> Measurement:
    """The quarantined reading as a measurement, its ``u`` at the measured scale."""
    y = math.exp(held.ln_y)
    return Measurement(y, held.noise * COVERAGE_FACTOR * y * scale)


def _at_least(
    belief: Posterior, point: dict[str, float], measurement: Measurement, age: int | None
) -> Posterior:
    """The posterior whose mean at ``point`` is at least ``ln(y − u)`` (module docstring).

    Raised by ``d``, the intercept's variance grows by ``d²`` (:func:`discount`).
    """
    y, u = measurement.value, measurement.uncertainty
    if y <= u:
        return belief
    at = belief.features(point, belief.edge_age(age))
    deficit = math.log(y - u) - float(at @ belief.mean_array)
    if deficit <= 0:
        return belief
    return discount(shifted(belief, deficit), deficit * deficit)


def _decision(
    state: Beliefs,
    operation: Operation,
    result: OperationResult,
    law: Decision,
    before: Posterior,
    after: Posterior,
) -> Decision:
    """A ``learn`` decision: the flags and margin of the law, the band and K of the cone.

    ``band_before`` is the band the part was made with (the cone's half-width at a cone
    setpoint, the band's at a band setpoint), ``band_after`` the new cone's half-width at the
    same setpoint; ``K_*``/``dK_*`` those of the learned model shown there.
    """
    point = {**result.setpoint, **operation.context}
    rel = operation.setpoint_rel_uncertainty
    settings = state.settings
    old = Cone(before, settings.z, settings.tau).shown(point, rel)
    new = Cone(after, settings.z, settings.tau).shown(point, rel)
    band_after = new.predict(point, rel).band
    shown = result.predicted.get(law.quantity)
    band_before = law.band_before if shown is None else shown.band
    action: Action = "hold"
    if law.flagged and band_after > band_before:
        action = "expand"
    elif band_after < band_before and not law.flagged:
        action = "shrink"
    why = law.reason if law.flagged else f"learned from {after.observations} measurements"
    if law.note == "regime_change":
        why = f"{law.reason}; learned from {after.observations} measurements"
    elif law.note == "below_band":
        why += " (note: below the band: the model is pessimistic here)"
    surprise = after.prior_widening - before.prior_widening  # only _surprised grows it here
    if surprise > 0:
        sd = 100 * math.sqrt(surprise)
        why += f"; past what the catalogue's K allows: its sd grown by {sd:.2g} % of K first"
    return replace(
        law,
        action=action,
        band_before=band_before,
        band_after=band_after,
        dK_before=old.dK,
        dK_after=new.dK,
        K_before=old.K,
        K_after=new.K,
        reason=why,
    )


def rescaled(belief: Posterior, prior_belief: Posterior, noise_scale2: float) -> Posterior:
    r"""The posterior with its readings counted at the noise variance's scale ``λ'``.

    With a Gaussian prior ``N(μ₀, Σ₀)`` the posterior precision is the prior's plus the
    readings', ``P = P₀ + D/λ``; the same readings at ``λ'`` give

    .. math:: P' = (1 − ρ) P_0 + ρ P, \qquad
              μ' = P'^{-1} \big((1 − ρ) P_0 μ_0 + ρ P μ\big), \qquad ρ = λ / λ'

    (exact without discounts, as a normal-inverse-gamma posterior's data term scales with the
    noise variance, Gelman et al. §14.8). Both ways: ``learn``'s scale starts high (an upper
    quantile of the chain's noise, :mod:`supervisor.rcb.noise`) and comes down as readings
    show a quiet chain, and the readings then weigh what they are worth. A belief that keeps
    its readings' own information ``J`` is re-weighed as ``P + (ρ − 1) J``, the same without
    discounts and, after one, leaving what the discount took
    (:func:`supervisor.rcb.information.reweighed`). One stored before 2026-12-06 takes the
    formula above, which a discount (a change's ``q``, the random walk ``τ``) makes extrapolate:
    where ``P − P₀`` is not positive semi-definite and ``ρ > 1`` the mean ran off (a posterior
    whose ``ln K`` overflowed, noise-scale 3): then the belief stays as it is, as where ``P'``
    loses definiteness.
    """
    if noise_scale2 == belief.noise_scale2:
        return belief
    # kept on the (immutable) belief: a reading asks for it, then its learning and the report's end
    cache: dict[float, tuple[Posterior, Posterior]] = belief.__dict__.setdefault("_rescaled", {})
    kept = cache.get(noise_scale2)
    if kept is None or not (kept[0] is prior_belief or kept[0] == prior_belief):
        kept = cache[noise_scale2] = (prior_belief, _rescaled(belief, prior_belief, noise_scale2))
    return kept[1]


def _rescaled(belief: Posterior, prior_belief: Posterior, noise_scale2: float) -> Posterior:
    rho = belief.noise_scale2 / noise_scale2
    if belief.readings_information is not None:  # the readings' own (J, h): P + (ρ − 1) J
        again = information.reweighed(belief, rho)
        return belief if again is None else replace(again, noise_scale2=noise_scale2)
    p0 = prior_belief.precision
    p = belief.precision
    if rho > 1.0 and not _readings_add_precision(belief, prior_belief):
        return belief
    precision = (1.0 - rho) * p0 + rho * p
    weighted = (1.0 - rho) * p0 @ prior_belief.mean_array + rho * p @ belief.mean_array
    precision = 0.5 * (precision + precision.T)
    if float(np.linalg.eigvalsh(precision)[0]) <= 0.0:
        return belief
    cov = np.linalg.inv(precision)
    cov = 0.5 * (cov + cov.T)
    mean = cov @ weighted
    return replace(
        belief,
        mean=tuple(float(m) for m in mean),
        cov=tuple(tuple(float(v) for v in row) for row in cov),
        noise_scale2=noise_scale2,
    )


def _readings_add_precision(belief: Posterior, prior_belief: Posterior) -> bool:
    """Whether ``P − P₀`` is positive semi-definite (to rounding): no discount took more."""
    p, p0 = belief.precision, prior_belief.precision
    data = 0.5 * ((p - p0) + (p - p0).T)
    return float(np.linalg.eigvalsh(data)[0]) >= -1e-9 * belief.precision_norm


def shifted(belief: Posterior, shift: float) -> Posterior:
    """The belief with its intercept moved by ``shift`` [ln]: a change the other operations showed.

    (:mod:`supervisor.rcb.common_cause`).
    """
    return information.shifted(belief, shift)


def moved(
    state: Beliefs, operation: Operation, quantity: str, shift: float, variance: float
) -> Posterior:
    """The belief of an operation that could not read a common change: moved by it, discounted."""
    return shifted(discount(belief_of(state, operation, quantity), variance), shift)


def as_started(start: Posterior, belief: Posterior | None) -> Posterior:
    """The prior ``belief`` learned from: ``start``, widened if its readings rejected it.

    (:attr:`~supervisor.rcb.posterior.Posterior.prior_widening`, :mod:`.prior_check`.) A
    start that carries a widening of its own (:func:`restarted`) holds it in its variance
    already: only what ``belief`` was widened beyond it is added.
    """
    widening = 0.0 if belief is None else belief.prior_widening - start.prior_widening
    return discount(start, widening) if widening > 0 else start


def restarted(start: Posterior, belief: Posterior | None) -> Posterior:
    """The start a plan goes back to when its bands are reset: ``start`` as it stands.

    A fleet prior the machine's readings let go stays let go (widened, and marked so that
    :mod:`.prior_check` does not judge it again): an engineer's reset forgets what the plan
    learned of its process, not that the machine lies outside the fleet.
    """
    if belief is None or belief.prior_widening <= start.prior_widening:
        return start
    return replace(as_started(start, belief), prior_widening=belief.prior_widening)


def discount(belief: Posterior, variance: float) -> Posterior:
    """The belief after a random-walk step ``variance`` of its intercept: old evidence weighs less.

    ``Σ₀₀ + q`` (:mod:`supervisor.rcb.monitor`: a change of the process sized by its innovation),
    the readings' own information with it (:func:`supervisor.rcb.information.stepped`).
    """
    return information.stepped(belief, variance)
