r"""Recursive Constraint Bounding: apply one part report, re-optimise, or halt.

For each operation and each measured constrained quantity, at the setpoint the part was made
with, the band law of :mod:`supervisor.rcb.law` shrinks the model's band where the part shows
room to spare and grows it where a measurement contradicts it (Ivester & Heigel, "Adaptive
Control Optimization"; DESIGN.md, "RCB"); the operations whose bands moved are re-optimised.
The state and its settings are :mod:`supervisor.rcb.state`.

When the grown bands leave no safe setpoint the plan *halts*
(:class:`supervisor.rcb.state.Halt`): the report is still applied (a part is never refused
because of what it measured), the setpoints stay those the part was made with, and only an
engineer's replan resumes (DESIGN.md, RCB step 4).

Strategies (:mod:`supervisor.rcb.strategies`):

``ivester``
    The law, on ΔK only: K keeps its catalogue value.
``bayes`` (beyond the paper)
    The law, and also a conjugate normal update of ``ln K``. The band is read as a
    prior, ``ln K ~ N(ln K₀, σ₀²)`` with ``σ₀ = (ΔK/K)/k`` (``k = 2``, the band as ±2σ). A
    measurement ``y ± u`` at setpoint ``x`` observes ``z = ln y − Σ e_i ln x_i`` with
    ``σ_z = (u/k)/y``. Before each observation the prior widens by the model discrepancy
    ``τ²`` (exponents that are slightly wrong make ``ln K`` look different at different
    setpoints: a random walk, as in a Kalman filter); then

    .. math::

        \frac{1}{σ'^2} = \frac{1}{σ^2 + τ^2} + \frac{1}{σ_z^2}, \qquad
        μ' = σ'^2 \left(\frac{μ}{σ^2 + τ^2} + \frac{z}{σ_z^2}\right)

    K becomes ``exp(μ')``, so a pessimistic model is corrected upward as well as an optimistic
    one downward, and the band becomes the larger of ``k·sqrt(σ'² + τ²)`` (the predicted
    spread at the next setpoint, which is not the one measured) and the Ivester law's result
    (never narrower than the law would allow, and never below the floor).
``learn`` (beyond the paper)
    The law as ``ivester`` (the proven-safe fallback), and a Bayesian regression of
    ``ln y`` on ``(1, ln x)`` per operation and quantity (:mod:`supervisor.rcb.posterior`), whose
    second-order-cone constraint the optimiser uses where it allows more than the band.

The noise scales a reading is read at (:mod:`supervisor.rcb.noise`): ``learn``'s likelihood
reads the measuring chain's, pooled over the operations it reads; the band law and the alarm
the operation's own ``ŝ`` (pooled, one operation's model error blinded every alarm), and the
chain's prudent ``P`` and bound ``Q`` scales only as :mod:`supervisor.rcb.law` says.

References
----------
.. [1] Ivester & Heigel (NIST), "Adaptive Control Optimization" and Table 5.
.. [2] Ivester, Danai & Malkin (1997), "Cycle-Time Reduction in Machining by Recursive
   Constraint Bounding", ASME J. Manuf. Sci. Eng. 119(2).
.. [3] Gelman et al., Bayesian Data Analysis, 3rd ed., §2.5 (normal mean, known variance).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

from models.powerlaw import PowerLawModel
from models.tool import Tool
from supervisor.errors import InfeasibleError
from supervisor.inputs.part_report import COVERAGE_FACTOR, Measurement, PartReport
from supervisor.inputs.plan import Operation
from supervisor.optimize.optimizer import optimize_operation
from supervisor.optimize.passes import measured_at
from supervisor.optimize.result import OperationResult, PlanResult
from supervisor.rcb import noise_watch
from supervisor.rcb import posterior as post
from supervisor.rcb import wear as wear_rise
from supervisor.rcb.common_cause import CommonShift, common_shifts
from supervisor.rcb.decision import Decision
from supervisor.rcb.judged import Judged, judge
from supervisor.rcb.law import apply_law
from supervisor.rcb.monitor import learned
from supervisor.rcb.monitor_state import Monitor
from supervisor.rcb.noise import NoiseScale
from supervisor.rcb.noise_check import chains_of, kept
from supervisor.rcb.posterior import Posterior
from supervisor.rcb.prior_check import checked, with_let_go
from supervisor.rcb.report_readings import report_readings, setpoints_of
from supervisor.rcb.shop_floor import changed, gross_breach, own_flags, quarantined
from supervisor.rcb.start import learned_cones as learned_cones  # callers import it from here
from supervisor.rcb.start import optimize_state
from supervisor.rcb.start import start as start  # callers import it from here
from supervisor.rcb.state import Halt, HaltedOperation, RcbState, prior_sigma
from supervisor.rcb.wear import WearRise


def update(
    state: RcbState, report: PartReport, made_with: PlanResult | None = None
) -> tuple[RcbState, tuple[Decision, ...]]:
    """Apply one part report: new bands, and a new setpoint version if any band moved.

    Parameters
    ----------
    state : RcbState
        The state before the report; it is not changed.
    report : PartReport
        Measurements per operation (and tool wear, when measured).
    made_with : PlanResult, optional
        The setpoints of ``report.setpoint_version`` when that is not the current version.

    Returns
    -------
    tuple[RcbState, tuple[Decision, ...]]
        The new state and one decision per measurement. When the new bands leave no safe
        setpoint, or a reading is past its limit by more than ``halt_over``, the new state is
        *halted* (:attr:`RcbState.halt`) with the setpoints and version unchanged; a halted
        state stays halted (its bands still learn).

    Raises
    ------
    InputError
        Unknown operation or quantity, or a setpoint version the state does not hold; nothing
        is applied.
    """
    setpoints = setpoints_of(state, report, made_with)
    operations = {op.name: op for op in state.plan.operations}
    results = {r.name: r for r in setpoints.operations}
    measured_items = report_readings(state, report, operations, results)
    decisions: list[Decision] = []
    gross: list[HaltedOperation] = []
    chains = chains_of(state.monitors, state.noise_priors)
    # measured_at: a pass's setpoint; then (op, made, quantity, measurement)
    at = [(*measured_at(operations[n], results[n], q), q, m) for n, q, m in measured_items]
    judged = [judge(state, *a, report, chains.get(a[2], NoiseScale())) for a in at]
    noise_priors = kept(state.noise_priors, state.monitors, judged)
    if noise_priors != state.noise_priors:  # a fleet's noise prior let go: judged again
        state = replace(state, noise_priors=noise_priors)
        chains = chains_of(state.monitors, noise_priors)
        judged = [judge(state, *a, report, chains.get(a[2], NoiseScale())) for a in at]
    state, judged, widened = checked(state, judged, report, chains)  # a fleet prior let go
    maps = _Maps.of(state)
    common = _common_changes(state, judged)
    for j in judged:
        noise = chains.get(j.quantity, NoiseScale())
        decision, over = _reading(state, maps, j, report, noise, common.get(j.quantity))
        decisions.append(with_let_go(decision, widened.get((j.op.name, j.quantity))))
        if over is not None:
            gross.append(over)
    noise_watch.watched(maps.monitors, (j.quantity for j in judged))  # a chain turned noisier
    return _after(state, maps, gross), tuple(decisions)


def _after(state: RcbState, maps: _Maps, gross: list[HaltedOperation]) -> RcbState:
    """The state after the report: settled, halted, or re-optimised when a band moved."""
    new = replace(state, **vars(maps))
    settled = state.settings.rule.settle(new, chains_of(maps.monitors, state.noise_priors))
    if settled:
        new = replace(new, posterior={**maps.posterior, **settled})
    if gross and state.halt is None:
        return replace(new, halt=_gross_halt(state, new, gross))
    unchanged = new.tools == state.tools and new.posterior == state.posterior
    if unchanged or state.halt is not None:
        return new
    try:
        new_setpoints = optimize_state(state, new.tools, new.posterior)
    except InfeasibleError:
        return replace(new, halt=_halt_of(state, new.tools, new.posterior))
    return replace(new, setpoints=new_setpoints, version=state.version + 1)


def _common_changes(state: RcbState, judged: Sequence[Judged]) -> dict[str, CommonShift]:
    """Per quantity, a change the part's operations show together; each rejudged by the rest."""
    on_high = [j for j in judged if j.watched.innovation is not None]  # none when confirmed
    common = common_shifts((j.quantity, i) for j in on_high if (i := j.watched.innovation))
    for quantity, shift in common.items():
        for index, j in enumerate(j for j in on_high if j.quantity == quantity):
            j.watched = j.rejudged(state.settings.exponent_sd, shift.shift(without=index))
    return common


@dataclass
class _Maps:
    """The state's maps after a report, copied from before it; :func:`_reading` fills them."""

    tools: dict[str, Tool]
    sigma: dict[tuple[str, str], float]
    seen: dict[tuple[str, str], float]
    posterior: dict[tuple[str, str], Posterior]
    wear: dict[tuple[str, str], WearRise]
    monitors: dict[tuple[str, str], Monitor]

    @classmethod
    def of(cls, state: RcbState) -> _Maps:
        """Copies of ``state``'s maps."""
        return cls(
            dict(state.tools),
            dict(state.sigma),
            dict(state.seen),
            dict(state.posterior),
            dict(state.wear),
            dict(state.monitors),
        )


def _reading(
    state: RcbState,
    new: _Maps,
    item: Judged,
    report: PartReport,
    noise: NoiseScale,
    common: CommonShift | None,
) -> tuple[Decision, HaltedOperation | None]:
    """One judged reading through the band law and the strategy, into ``new``.

    ``common``: the quantity's change in every operation of the part, when the report shows
    one (:mod:`supervisor.rcb.common_cause`); a quarantined reading's operation moves by it.
    ``noise``: the measuring chain's noise scale before the report
    (:func:`~.noise_check.chains_of`), which ``learn``'s likelihood reads; the band law and
    the alarm read the operation's own ``ŝ``, and the chain's prudent scale only near the
    limit and over the prediction (``alarm_u``, module docstring). Returns the decision and,
    for a reading past its limit by more than ``halt_over``, what halts the plan.
    """
    settings = state.settings
    op, made, quantity, measurement = item.op, item.made, item.quantity, item.measurement
    monitor, watched = item.monitor, item.watched
    key = (op.name, quantity)
    age = report.edge_parts.get(op.name)
    point = {**made.setpoint, **op.context}
    new.monitors[key] = watched.monitor
    if not watched.learns:  # quarantined: a decision to show, nothing learned
        return _quarantine(state, new, item, common, noise), None
    scaled = Measurement(measurement.value, measurement.uncertainty * monitor.scale)
    tools, sigma, seen, rises, posterior = new.tools, new.sigma, new.seen, new.wear, new.posterior
    judged = _forgotten(state, sigma, key, watched.forget)
    projection = 1.0
    rise = _wear_after(state, op, made, quantity, scaled, None if watched.changed else age)
    if rise is not None:
        rises[key] = rise
        projection = rise.factor(age, settings.coverage_k)
    moved = settings.exponent_sd if watched.verdict == "change" else 0.0
    prudent_u, bound_u = _scaled_u(noise, monitor, watched.monitor, measurement.uncertainty)
    evidence = scaled
    if common is not None and watched.verdict == "change":  # at least what the others showed
        floor = item.shifted(watched.shift, watched.forget, noise.prudent_scale)
        if floor is not None and _upper(floor) > scaled.value + max(scaled.uncertainty, bound_u):
            evidence = floor
    decision, model, sigma[key], seen[key] = apply_law(
        judged, op, made, quantity, evidence, projection, moved, prudent_u, bound_u
    )
    if evidence is not scaled:  # learned at the others' shift, flagged on its own reading
        own = apply_law(judged, op, made, quantity, scaled, projection, moved, prudent_u, bound_u)
        decision = own_flags(decision, own[0])
    decision = replace(decision, measured=measurement.value, uncertainty=measurement.uncertainty)
    if watched.changed:
        decision = changed(decision, watched, None if common is None else common.z)
    prudent = Measurement(measurement.value, prudent_u)
    keep, belief, decision = settings.rule.learn(state, op, made, decision, prudent, watched, age)
    if keep:
        tools[op.name] = _with_model(tools[op.name], model)
    if belief is not None:
        posterior[key] = belief
    new.monitors[key] = learned(watched.monitor, measurement, point, age)
    return decision, gross_breach(op, quantity, scaled, settings.halt_over)


def _scaled_u(noise: NoiseScale, before: Monitor, after: Monitor, u: float) -> tuple[float, float]:
    """``(P u, Q u)`` at the chain's belief with this reading's evidence (``after``'s)."""
    shape = noise.shape + after.chain_shape - before.chain_shape
    prudent_scale, bound_scale = NoiseScale(
        shape, noise.rate + after.chain_rate - before.chain_rate
    ).scales()
    return u * prudent_scale, u * bound_scale


def _quarantine(
    state: RcbState, new: _Maps, item: Judged, common: CommonShift | None, noise: NoiseScale
) -> Decision:
    """A quarantined reading: a decision to show, nothing learned; an unread change moves."""
    op, quantity = item.op, item.quantity
    law, *_ = apply_law(state, op, item.made, quantity, item.measurement)
    new.seen[(op.name, quantity)] = state.seen.get((op.name, quantity), 0.0)  # 0 covers nothing
    if common is not None:  # the change it could not read: as the others showed it
        _unread_change(state, new, item, common, noise.prudent_scale)
    return quarantined(law, item.watched.sigma)


def _forgotten(
    state: RcbState, sigma: dict[tuple[str, str], float], key: tuple[str, str], forget: float
) -> RcbState:
    """``state`` with the old regime's evidence of ``key`` weighing less (``forget > 0``)."""
    if forget <= 0:
        return state
    model = state.tools[key[0]].models[key[1]]
    before = state.sigma.get(key, prior_sigma(model, state.settings))
    sigma[key] = state.settings.rule.forget(before, forget)
    return replace(state, sigma=sigma)


def _upper(measurement: Measurement) -> float:
    return measurement.value + measurement.uncertainty


def _unread_change(
    state: RcbState, new: _Maps, item: Judged, common: CommonShift, scale: float
) -> None:
    """An operation whose reading of a common change was quarantined moves by the others'.

    The band law takes the reading the operation would have had, what it expected moved by
    the shift (:meth:`Judged.shifted`), and may only grow from it; ``learn``'s posterior
    moves by the shift (:meth:`supervisor.rcb.strategies.Strategy.moved`).
    """
    op, quantity = item.op, item.quantity
    key = (op.name, quantity)
    shift, variance = common.shift()
    last, edge = item.shifted(shift, variance, scale), _edge_shifted(state, item, shift, variance)
    virtual = edge if last is None or _upper(edge) > _upper(last) else last  # the higher
    moved = state.settings.exponent_sd  # a change, as a flagged reading of one backs off
    law, model, sigma, seen = apply_law(state, op, item.made, quantity, virtual, 1.0, moved)
    if law.action == "expand":
        new.tools[op.name] = _with_model(new.tools[op.name], model)
        new.sigma[key], new.seen[key] = sigma, seen
    belief = state.settings.rule.moved(state, op, quantity, shift, variance)
    if belief is not None:
        new.posterior[key] = belief


def _edge_shifted(state: RcbState, item: Judged, shift: float, variance: float) -> Measurement:
    """The band's edge moved by the others' change: ``(Y + ΔY)·exp(δ̂)``, over the new truth.

    The band covered the truth before the change, whatever the last reading's noise was.
    """
    model = state.tools[item.op.name].models[item.quantity]
    point = {**item.made.setpoint, **item.op.context}
    edge = model.predict(point, item.op.setpoint_rel_uncertainty)
    value = (edge.value + edge.band) * math.exp(shift)
    return Measurement(value, COVERAGE_FACTOR * value * math.sqrt(variance))


def _wear_after(
    state: RcbState,
    operation: Operation,
    result: OperationResult,
    quantity: str,
    measurement: Measurement,
    age: int | None,
) -> WearRise | None:
    """The rise per part of a wearing quantity after this reading (None: it does not wear)."""
    edge_max = post.edge_max_of(operation, quantity)
    if not edge_max:
        return None
    settings = state.settings
    before = state.wear.get((operation.name, quantity))
    if before is None:
        before = wear_rise.prior(edge_max, settings.edge_sd)
    elif before.edge_max != edge_max:  # a replan changed parts_per_edge: the rise per part stays
        before = replace(before, edge_max=edge_max)
    exponents = state.tools[operation.name].models[quantity].exponents
    point = {**result.setpoint, **operation.context}
    return wear_rise.observe(
        before, age, measurement, point, exponents, settings.coverage_k, settings.exponent_sd
    )


def _halt_of(
    state: RcbState, tools: Mapping[str, Tool], posterior: Mapping[tuple[str, str], Posterior]
) -> Halt:
    """Every operation that cannot run under ``tools``, with its conflicts."""
    halted = []
    cones = learned_cones(replace(state, posterior=posterior))
    for op in state.plan.operations:
        try:
            optimize_operation(op, tools[op.name], state.plan.machine, cones.get(op.name))
        except InfeasibleError as err:
            halted.append(HaltedOperation(op.name, err.conflicts, err.against, str(err)))
    return Halt(tuple(halted))


def _gross_halt(state: RcbState, new: RcbState, gross: list[HaltedOperation]) -> Halt:
    """The halt of readings past their limits by more than ``halt_over``.

    Each such operation names its reading, and the limits its grown bands cannot meet where
    they cannot; the other operations with no safe setpoint follow.
    """
    infeasible = {o.operation: o for o in _halt_of(state, new.tools, new.posterior).operations}
    halted = []
    for over in gross:
        also = infeasible.pop(over.operation, None)
        if also is None:
            halted.append(over)
            continue
        message = f"{over.message}; {also.message}"
        halted.append(replace(also, message=message))
    return Halt((*halted, *infeasible.values()))


def _with_model(tool: Tool, model: PowerLawModel) -> Tool:
    if tool.models[model.quantity] == model:
        return tool
    return replace(tool, models={**tool.models, model.quantity: model})
