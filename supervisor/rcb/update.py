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

References
----------
.. [1] Ivester & Heigel (NIST), "Adaptive Control Optimization" and Table 5.
.. [2] Ivester, Danai & Malkin (1997), "Cycle-Time Reduction in Machining by Recursive
   Constraint Bounding", ASME J. Manuf. Sci. Eng. 119(2).
.. [3] Gelman et al., Bayesian Data Analysis, 3rd ed., §2.5 (normal mean, known variance).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

from models.errors import InputError
from models.powerlaw import PowerLawModel
from models.tool import Tool
from supervisor.errors import InfeasibleError
from supervisor.inputs.part_report import Measurement, PartReport
from supervisor.inputs.plan import Operation, Plan
from supervisor.optimize.optimizer import optimize_operation, optimize_plan
from supervisor.optimize.passes import measured_at
from supervisor.optimize.result import OperationResult, PlanResult
from supervisor.rcb import posterior as post
from supervisor.rcb import wear as wear_rise
from supervisor.rcb.law import apply_law, tool_life_measured
from supervisor.rcb.posterior import Posterior
from supervisor.rcb.state import (
    Action,
    Decision,
    Halt,
    HaltedOperation,
    RcbSettings,
    RcbState,
    prior_sigma,
)
from supervisor.rcb.wear import WearRise


def start(plan: Plan, settings: RcbSettings | None = None) -> RcbState:
    """The initial state: catalogue models, robust optimum as setpoint version 1."""
    settings = settings or RcbSettings()
    tools = {op.name: plan.tools[op.tool] for op in plan.operations}
    sigma = {
        (op, q): prior_sigma(m, settings)
        for op, tool in tools.items()
        for q, m in tool.models.items()
    }
    return RcbState(plan, tools, optimize_plan(plan, tools), 1, settings, sigma)


def learned_cones(state: RcbState) -> dict[str, dict[str, post.Cone]]:
    """The cone constraints of a ``learn`` state, per operation and quantity."""
    if not state.settings.rule.learns_model:
        return {}
    cones: dict[str, dict[str, post.Cone]] = {}
    for (name, quantity), belief in state.posterior.items():
        cones.setdefault(name, {})[quantity] = post.Cone(
            belief, state.settings.z, state.settings.tau
        )
    return cones


def optimize_state(
    state: RcbState, tools: Mapping[str, Tool], posterior: Mapping[tuple[str, str], Posterior]
) -> PlanResult:
    """The setpoints of ``state``'s plan under ``tools`` (and the cones of ``posterior``)."""
    trial = replace(state, tools=tools, posterior=posterior)
    return optimize_plan(
        state.plan,
        tools,
        previous=(state.setpoints, state.tools, learned_cones(state)),
        cones=learned_cones(trial),
    )


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
        setpoint, the new state is *halted* (:attr:`RcbState.halt`) with the setpoints and
        version unchanged; a halted state stays halted (its bands still learn).

    Raises
    ------
    InputError
        Unknown operation or quantity, or a setpoint version the state does not hold; nothing
        is applied.
    """
    setpoints = _setpoints_of(state, report, made_with)
    operations = {op.name: op for op in state.plan.operations}
    results = {r.name: r for r in setpoints.operations}
    for name in [*report.measurements, *report.tool_wear]:
        if name not in operations:
            raise InputError(f"operations.{name}", name, f"not an operation of {state.plan.name!r}")
    tools = dict(state.tools)
    sigma = dict(state.sigma)
    seen = dict(state.seen)
    posterior = dict(state.posterior)
    rises = dict(state.wear)
    measured_items = [
        (name, quantity, measurement)
        for name, measured in report.measurements.items()
        for quantity, measurement in measured.items()
    ]
    for name, wear in report.tool_wear.items():
        _check_quantity(tools[name], name, "tool_life_mm3")
        wear_measured = tool_life_measured(
            state, *measured_at(operations[name], results[name], "tool_life_mm3"), wear
        )
        measured_items.append((name, "tool_life_mm3", wear_measured))
    for name, quantity, _ in measured_items:  # check the whole report before applying any
        _check_quantity(tools[name], name, quantity)
    decisions: list[Decision] = []
    learns = state.settings.rule.learns_model
    for name, quantity, measurement in measured_items:
        key = (name, quantity)
        op, made = measured_at(operations[name], results[name], quantity)  # a pass's setpoint
        age = report.edge_parts.get(name)
        projection = 1.0
        rise = _wear_after(state, op, made, quantity, measurement, age)
        if rise is not None:
            rises[key] = rise
            projection = rise.factor(age, state.settings.coverage_k)
        decision, model, sigma[key], seen[key] = apply_law(
            state, op, made, quantity, measurement, projection
        )
        if not learns:
            decisions.append(decision)
            tools[name] = _with_model(tools[name], model)
            continue
        # learn: the fallback band only ever grows (when a measurement contradicts it); what
        # a part teaches goes to the posterior, and the decision reports the cone
        if decision.action == "expand":
            tools[name] = _with_model(tools[name], model)
        before = posterior.get(key) or post.prior(
            state.plan.tools[op.tool].models[quantity],
            op,
            state.settings.coverage_k,
            state.settings.exponent_sd,
            state.settings.edge_sd,
        )
        after = before
        if measurement.value > 0 and measurement.uncertainty > 0:
            point = {**made.setpoint, **op.context}
            after = post.observe(
                before,
                point,
                measurement,
                state.settings.coverage_k,
                state.settings.tau,
                report.edge_parts.get(name),
            )
        posterior[key] = after
        decisions.append(_learned_decision(state, op, made, decision, before, after))
    unchanged = tools == dict(state.tools) and posterior == dict(state.posterior)
    if unchanged or state.halt is not None:
        return replace(
            state, tools=tools, sigma=sigma, seen=seen, posterior=posterior, wear=rises
        ), tuple(decisions)
    try:
        new_setpoints = optimize_state(state, tools, posterior)
    except InfeasibleError:
        halt = _halt_of(state, tools, posterior)
        halted = replace(
            state, tools=tools, sigma=sigma, seen=seen, posterior=posterior, halt=halt, wear=rises
        )
        return halted, tuple(decisions)
    new = replace(
        state,
        tools=tools,
        setpoints=new_setpoints,
        version=state.version + 1,
        sigma=sigma,
        seen=seen,
        posterior=posterior,
        wear=rises,
    )
    return new, tuple(decisions)


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


def _learned_decision(
    state: RcbState,
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
    old = post.display_model(post.Cone(before, settings.z, settings.tau), point, rel)
    new = post.display_model(post.Cone(after, settings.z, settings.tau), point, rel)
    band_after = new.predict(point, rel).band
    shown = result.predicted.get(law.quantity)
    band_before = law.band_before if shown is None else shown.band
    action: Action = "hold"
    if law.flagged and band_after > band_before:
        action = "expand"
    elif band_after < band_before and not law.flagged:
        action = "shrink"
    why = law.reason if law.flagged else f"learned from {after.observations} measurements"
    if law.note:
        why += " (note: below the band: the model is pessimistic here)"
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


def _setpoints_of(state: RcbState, report: PartReport, made_with: PlanResult | None) -> PlanResult:
    if report.setpoint_version == state.version:
        return state.setpoints
    if made_with is not None and 1 <= report.setpoint_version < state.version:
        return made_with
    raise InputError(
        "setpoint_version",
        report.setpoint_version,
        f"unknown here: the current version is {state.version}",
    )


def _check_quantity(tool: Tool, operation: str, quantity: str) -> None:
    if quantity not in tool.models:
        known = ", ".join(q for q in tool.models if q != "tool_life_mm3") or "none"
        raise InputError(
            f"operations.{operation}.{quantity}",
            quantity,
            f"tool {tool.name!r} has no model of it; measurable: {known}",
        )


def _with_model(tool: Tool, model: PowerLawModel) -> Tool:
    if tool.models[model.quantity] == model:
        return tool
    return replace(tool, models={**tool.models, model.quantity: model})
