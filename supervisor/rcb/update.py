r"""Recursive Constraint Bounding: shrink a model's band where a part shows room to spare.

For each operation and each measured constrained quantity, at the setpoint the part was made
with (Ivester & Heigel, "Adaptive Control Optimization"; DESIGN.md, "RCB"):

.. math::

    M = Y_{lim} - (y + u), \qquad
    \Delta Y' = \max(\Delta Y - \alpha M, \; \Delta Y_{floor}) \quad (M > 0)

with ``α = 0.25`` ("one or more of the uncertainty parameters is reduced by a fraction (0.25) of
the difference"). The law is one-sided, as the paper's: only the side of the band that guards
the limit matters. For a maximum:

- ``y − u`` above the limit: ``breach`` (the measurement proves the limit crossed, the
  decision rule of ISO 14253-1 for nonconformance); else ``y + u`` above the band's upper
  edge ``Y + ΔY``: ``above_band`` (the band must cover measured + u, as the paper's bands
  "encompass all of the points"). Either is flagged and the band grows to ``y + u − Y`` so it
  covers the measurement (action ``expand``); it never shrinks then. ``y + u`` over the limit
  with ``y − u`` under it is not a breach: at the physical limit the noise alone does that.
- otherwise the margin law above; a reading whose ``y + u`` lies under the band's lower edge
  carries the note ``below_band`` (the model is pessimistic there), never a flag: a part that
  came out better than predicted is no reason to widen a band.
- a ``learn`` setpoint held by a cone (which bounds the true value, not a measurement) is
  ``above_band`` only when ``y − u`` is past the cone's edge; its fallback band still grows
  to cover ``y + u``, unflagged.

Minima (tool life) mirror this: ``M = (y − u) − Y_lim``, a flag ``breach`` (``y + u`` under
the limit) or ``below_band`` (``y − u`` under the lower edge), the note ``above_band``.
``ΔY'`` is stored as a new ``ΔK`` through the first-order law of
:func:`models.powerlaw.relative_band`: ``ΔK'/K = sqrt((ΔY'/Y)² − Σ(e_i Δx_i/x_i)²)``.

When the grown bands leave no safe setpoint the plan *halts* (:class:`Halt`): the report is
still applied (a part is never refused because of what it measured), the setpoints stay those
the part was made with, and only an engineer's replan resumes (DESIGN.md, RCB step 4).

Strategies (:mod:`supervisor.rcb.strategies`):

``ivester``
    The law above, on ΔK only: K keeps its catalogue value.
``bayes`` (beyond the paper)
    The law above, and also a conjugate normal update of ``ln K``. The band is read as a
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
    The law above as ``ivester`` (the proven-safe fallback), and a Bayesian regression of
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

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Literal

from models.errors import InputError
from models.powerlaw import PowerLawModel, Prediction
from models.quantities import MODEL_QUANTITIES
from models.tool import Tool
from supervisor.errors import Conflict, InfeasibleError
from supervisor.inputs.part_report import Measurement, PartReport, ToolWear
from supervisor.inputs.plan import PARTS_PER_EDGE, Operation, Plan
from supervisor.optimize.optimizer import (
    RECHECK_RTOL,
    OperationResult,
    PlanResult,
    optimize_operation,
    optimize_plan,
)
from supervisor.rcb import posterior as post
from supervisor.rcb.posterior import Posterior
from supervisor.rcb.strategies import (
    DEFAULT_ALPHA,
    DEFAULT_STRATEGY,
    REGISTRY,
    STRATEGY_NAMES,
    Strategy,
)

Action = Literal["shrink", "hold", "expand"]
#: What made a decision flagged: the limit crossed, or the measurement beyond the band's
#: guarding edge (``above_band`` for a maximum, ``below_band`` for a minimum).
Flag = Literal["breach", "above_band", "below_band"]
#: Information, never a flag: the measurement beyond the band's other edge.
Note = Literal["below_band", "above_band"]
#: A measurement is past a band's edge only beyond this fraction of it: an optimum sits on
#: its limit within the optimiser's re-check tolerance.
EDGE_RTOL = RECHECK_RTOL
#: Names of the registered strategies (:mod:`supervisor.rcb.strategies`).
STRATEGIES: tuple[str, ...] = STRATEGY_NAMES


@dataclass(frozen=True)
class RcbSettings:
    """How bands are updated.

    Parameters
    ----------
    strategy : str
        A name of :data:`supervisor.rcb.strategies.REGISTRY` (module docstring).
    alpha : float
        Fraction of the margin by which a band shrinks, ``0 < alpha <= 1`` (paper: 0.25).
    floors : Mapping[str, float]
        Least band ``ΔY`` per quantity, in its unit; default: the measurement's uncertainty.
    coverage_k : float
        ``bayes`` and ``learn``: the band is ``k σ`` of ``ln K`` (2: the paper's ±2σ).
    discrepancy : float, optional
        ``τ``, the model discrepancy [-]: ``bayes`` adds it to ``σ`` before each observation,
        ``learn`` takes it as the intercept's random walk per part; default: the strategy's
        (:attr:`supervisor.rcb.strategies.Strategy.default_discrepancy`).
    z : float
        ``learn``: the cone's multiple of the posterior standard deviation of ``ln y``.
    exponent_sd : float
        ``learn``: prior standard deviation of each exponent relative to its value [-], for a
        model without a fitted covariance.
    edge_sd : float
        ``learn``: prior standard deviation of the rise over one edge's life, in ``ln`` [-].
    """

    strategy: str = DEFAULT_STRATEGY
    alpha: float = DEFAULT_ALPHA
    floors: Mapping[str, float] = field(default_factory=dict)
    coverage_k: float = 2.0
    discrepancy: float | None = None
    z: float = post.DEFAULT_Z
    exponent_sd: float = post.DEFAULT_EXPONENT_SD
    edge_sd: float = post.DEFAULT_EDGE_SD

    def __post_init__(self) -> None:
        if self.strategy not in REGISTRY:
            raise InputError("strategy", self.strategy, f"expected one of: {', '.join(REGISTRY)}")
        if not (0 < self.alpha <= 1):
            raise InputError("alpha", self.alpha, "must be in (0, 1]")
        for quantity, floor in self.floors.items():
            if quantity not in MODEL_QUANTITIES:
                raise InputError(f"floors.{quantity}", floor, "unknown quantity")
            if not (math.isfinite(floor) and floor >= 0):
                raise InputError(f"floors.{quantity}", floor, "must be a number >= 0")
        for name in ("coverage_k", "z"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0 < value <= 100):
                raise InputError(name, value, "must be a number in (0, 100]")
        if self.discrepancy is None:
            object.__setattr__(self, "discrepancy", self.rule.default_discrepancy)
        for name in ("discrepancy", "exponent_sd", "edge_sd"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0 <= value <= 10):
                raise InputError(name, value, "must be a number in [0, 10]")

    @property
    def rule(self) -> Strategy:
        """The strategy object of :attr:`strategy`."""
        return REGISTRY[self.strategy]

    @property
    def tau(self) -> float:
        """The discrepancy in force (the strategy's default when none was given)."""
        return self.rule.default_discrepancy if self.discrepancy is None else self.discrepancy


@dataclass(frozen=True)
class Decision:
    """What one measurement did to one band.

    ``margin`` is ``limit − (measured + u)`` for a maximum and ``(measured − u) − limit`` for
    a minimum (``margin`` and ``limit`` are ``None`` for a quantity without a limit);
    ``band_*`` are ``ΔY`` at the setpoint the part was made with. ``flag`` says why a
    decision is flagged (``breach``: the limit crossed; ``above_band``/``below_band``: past
    the band's guarding edge), ``note`` is information only (``below_band`` for a maximum:
    the model is pessimistic there); ``flagged`` is ``flag is not None``.
    """

    operation: str
    quantity: str
    action: Action
    margin: float | None
    band_before: float
    band_after: float
    dK_before: float
    dK_after: float
    K_before: float
    K_after: float
    predicted: float
    measured: float
    uncertainty: float
    limit: float | None
    flagged: bool
    reason: str
    flag: Flag | None = None
    note: Note | None = None


@dataclass(frozen=True)
class HaltedOperation:
    """An operation that no setpoint can run under the bands in force."""

    operation: str
    conflicts: tuple[Conflict, ...]
    against: tuple[str, ...]
    message: str


@dataclass(frozen=True)
class Halt:
    """Why a plan halted: the operations whose limits cannot all be met, and by how much."""

    operations: tuple[HaltedOperation, ...]

    @property
    def message(self) -> str:
        """One line per halted operation."""
        return "; ".join(o.message for o in self.operations)


@dataclass(frozen=True)
class RcbState:
    """Everything RCB needs between parts.

    Parameters
    ----------
    plan : Plan
        The plan (limits, bounds, catalogue models).
    tools : Mapping[str, Tool]
        Per operation name, the tool with the models in force: bands are kept per operation
        and quantity, as Table 5 treats steps 2 and 3 (both VCMR331).
    setpoints : PlanResult
        The current robust optimum under those models (while halted: the last setpoints).
    version : int
        Setpoint version, 1 for the initial robust optimum.
    settings : RcbSettings
        The update law.
    sigma : Mapping[tuple[str, str], float]
        ``bayes``: posterior standard deviation of ``ln K`` per (operation, quantity).
    seen : Mapping[tuple[str, str], float]
        Per (operation, quantity), the most demanding measurement so far as a K-equivalent:
        the largest ``(y + u)/Π x_i^e_i`` for a maximum, the smallest ``(y − u)/Π x_i^e_i``
        for a minimum. A band never shrinks so far that it stops covering it, as Ivester &
        Heigel's bands are "the range of K that encompasses all of the points".
    posterior : Mapping[tuple[str, str], Posterior]
        ``learn``: the posterior of ``(ln K, exponents)`` per (operation, quantity) measured.
    halt : Halt or None
        Set when the bands leave no safe setpoint; only a replan clears it.
    """

    plan: Plan
    tools: Mapping[str, Tool]
    setpoints: PlanResult
    version: int
    settings: RcbSettings
    sigma: Mapping[tuple[str, str], float] = field(default_factory=dict)
    seen: Mapping[tuple[str, str], float] = field(default_factory=dict)
    posterior: Mapping[tuple[str, str], Posterior] = field(default_factory=dict)
    halt: Halt | None = None


def prior_sigma(model: PowerLawModel, settings: RcbSettings) -> float:
    """σ of ln K before any measurement: the band read as ±k σ, ``(ΔK/K)/k``."""
    return (model.dK / model.K) / settings.coverage_k


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
    measured_items = [
        (name, quantity, measurement)
        for name, measured in report.measurements.items()
        for quantity, measurement in measured.items()
    ]
    for name, wear in report.tool_wear.items():
        _check_quantity(tools[name], name, "tool_life_mm3")
        wear_measured = _tool_life_measured(state, operations[name], results[name], wear)
        measured_items.append((name, "tool_life_mm3", wear_measured))
    for name, quantity, _ in measured_items:  # check the whole report before applying any
        _check_quantity(tools[name], name, quantity)
    decisions: list[Decision] = []
    learns = state.settings.rule.learns_model
    for name, quantity, measurement in measured_items:
        key = (name, quantity)
        decision, model, sigma[key], seen[key] = _apply(
            state, operations[name], results[name], quantity, measurement
        )
        if not learns:
            decisions.append(decision)
            tools[name] = _with_model(tools[name], model)
            continue
        # learn: the fallback band only ever grows (when a measurement contradicts it); what
        # a part teaches goes to the posterior, and the decision reports the cone
        if decision.action == "expand":
            tools[name] = _with_model(tools[name], model)
        op = operations[name]
        before = posterior.get(key) or post.prior(
            state.plan.tools[op.tool].models[quantity],
            op,
            state.settings.coverage_k,
            state.settings.exponent_sd,
            state.settings.edge_sd,
        )
        after = before
        if measurement.value > 0 and measurement.uncertainty > 0:
            point = {**results[name].setpoint, **op.context}
            after = post.observe(
                before,
                point,
                measurement,
                state.settings.coverage_k,
                state.settings.tau,
                report.edge_parts.get(name),
            )
        posterior[key] = after
        decisions.append(_learned_decision(state, op, results[name], decision, before, after))
    unchanged = tools == dict(state.tools) and posterior == dict(state.posterior)
    if unchanged or state.halt is not None:
        return replace(state, tools=tools, sigma=sigma, seen=seen, posterior=posterior), tuple(
            decisions
        )
    try:
        new_setpoints = optimize_state(state, tools, posterior)
    except InfeasibleError:
        halt = _halt_of(state, tools, posterior)
        halted = replace(state, tools=tools, sigma=sigma, seen=seen, posterior=posterior, halt=halt)
        return halted, tuple(decisions)
    new = replace(
        state,
        tools=tools,
        setpoints=new_setpoints,
        version=state.version + 1,
        sigma=sigma,
        seen=seen,
        posterior=posterior,
    )
    return new, tuple(decisions)


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


def _limit(operation: Operation, quantity: str) -> float | None:
    if quantity == "tool_life_mm3":
        parts = operation.limits.get(PARTS_PER_EDGE)
        return None if parts is None else parts * operation.volume_mm3
    return operation.limits.get(quantity)


def _tool_life_measured(
    state: RcbState, operation: Operation, result: OperationResult, wear: ToolWear
) -> Measurement:
    """Volume the edge would remove to the allowable wear, from wear measured after ``V``.

    Eq. 8 gives ``mr ∝ w^e_w``, so an edge that reached ``VB`` after ``V`` reaches the
    allowable ``w`` after ``V (w/VB)^e_w``; first-order uncertainty ``e_w·u_VB/VB``.
    """
    model = state.tools[operation.name].models["tool_life_mm3"]
    e_w = model.exponents.get("flank_wear_mm", 0.0)
    vb = wear.flank_wear_mm.value
    if not (vb > 0 and wear.volume_mm3 > 0):
        raise InputError(
            f"operations.{operation.name}.tool_wear", vb, "wear and volume must be > 0"
        )
    allowable = operation.context["flank_wear_mm"]
    volume = wear.volume_mm3 * (allowable / vb) ** e_w
    return Measurement(volume, volume * abs(e_w) * wear.flank_wear_mm.uncertainty / vb)


def _apply(
    state: RcbState,
    operation: Operation,
    result: OperationResult,
    quantity: str,
    measurement: Measurement,
) -> tuple[Decision, PowerLawModel, float, float]:
    """The one-sided law for one measured quantity: decision, model, σ of ln K, ``seen``."""
    settings = state.settings
    model = state.tools[operation.name].models[quantity]
    sigma = state.sigma.get((operation.name, quantity), prior_sigma(model, settings))
    point = {**result.setpoint, **operation.context}
    rel = operation.setpoint_rel_uncertainty
    predicted = model.predict(point, rel)
    # flags and notes are against the prediction the part was made with: the band's, or for
    # a ``learn`` setpoint held by a cone, the learned value and the cone's half-width
    shown = result.predicted.get(quantity, predicted)
    y, u = measurement.value, measurement.uncertainty
    limit = _limit(operation, quantity)
    is_max = MODEL_QUANTITIES[quantity].sense == "max"
    floor = settings.floors.get(quantity, u)

    def decision(
        action: Action,
        new: PowerLawModel,
        margin: float | None,
        why: str,
        flag: Flag | None = None,
        note: Note | None = None,
    ) -> Decision:
        return Decision(
            operation=operation.name,
            quantity=quantity,
            action=action,
            margin=margin,
            band_before=predicted.band,
            band_after=new.predict(point, rel).band,
            dK_before=model.dK,
            dK_after=new.dK,
            K_before=model.K,
            K_after=new.K,
            predicted=shown.value,
            measured=y,
            uncertainty=u,
            limit=limit,
            flagged=flag is not None,
            reason=why,
            flag=flag,
            note=note,
        )

    # the side of the measurement that guards the limit, and the band's edges in that sense
    guard = y + u if is_max else max(y - u, 0.0)
    # the most demanding measurement so far, as a K-equivalent (RcbState.seen)
    shape = predicted.value / model.K  # Π x_i^e_i at the part's setpoint
    edge_now = guard / shape
    before = state.seen.get((operation.name, quantity), edge_now)
    worst = max(before, edge_now) if is_max else min(before, edge_now)
    if limit is None:
        hold = decision("hold", model, None, "no limit on this quantity")
        return hold, model, sigma, worst
    margin = limit - guard if is_max else guard - limit
    # the far side of y ± u: past the limit, the measurement proves the limit crossed
    far_side = max(y - u, 0.0) if is_max else y + u
    if result.robust_by == "cone":  # a cone bounds the true value: the far side of y ± u
        beyond_guard = _past(far_side, shown, is_max)
    else:  # a band covers measured ± u (Ivester & Heigel: "encompasses all of the points")
        beyond_guard = _past(guard, shown, is_max)
    beyond_other = guard < shown.lower if is_max else guard > shown.upper
    # the fallback band of a cone setpoint: past its edge it grows, but is not flagged
    fallback_only = result.robust_by == "cone" and _past(guard, predicted, is_max)
    flag: Flag | None = None
    if far_side > limit if is_max else far_side < limit:  # nonconformance proven
        flag = "breach"
    elif beyond_guard:
        flag = "above_band" if is_max else "below_band"
    note: Note | None = None
    if beyond_other and flag is None:
        note = "below_band" if is_max else "above_band"

    rule = settings.rule
    model, sigma = rule.adjust(model, point, measurement, sigma, settings.coverage_k, settings.tau)
    y_new = model.predict(point, rel)
    # the band keeps covering every measurement so far: K(1 ± ΔY/Y) reaches the worst one
    cover = (worst / model.K - 1.0 if is_max else 1.0 - worst / model.K) * y_new.value
    if flag is not None or fallback_only:
        reach = guard - y_new.value if is_max else y_new.value - guard
        new = _with_band(model, max(predicted.band, reach, cover), y_new.value, point, rel)
        action: Action = "expand" if new.predict(point, rel).band > predicted.band else "hold"
        if flag is None:
            why = "inside the learned cone; the fallback band grows to cover it"
            return decision(action, new, margin, why, note=note), new, sigma, worst
        where = "measured − u past the limit" if flag == "breach" else f"measured + u {flag}"
        flagged = decision(action, new, margin, f"{where}: never shrink; band covers it", flag)
        return flagged, new, sigma, worst
    below = " (note: below the band: the model is pessimistic here)" if note else ""
    if margin <= 0:
        new = _with_band(model, max(predicted.band, cover), y_new.value, point, rel)
        no_margin = decision("hold", new, margin, "no margin: measured + u at the limit", note=note)
        return no_margin, new, sigma, worst
    band = max(predicted.band - settings.alpha * margin, floor)
    band = rule.least_band(band, sigma, y_new.value, settings.coverage_k, settings.tau)
    why = f"margin {margin:.4g} > 0: band shrinks by {settings.alpha:g} of it (floor {floor:.4g})"
    if cover > band:
        band = cover
        why = "margin > 0, but the band keeps covering the most demanding measurement so far"
    if band >= predicted.band or math.isclose(band, predicted.band, rel_tol=1e-12):
        new = _with_band(model, predicted.band, y_new.value, point, rel)
        held = decision("hold", new, margin, "band at its floor" + below, note=note)
        return held, new, sigma, worst
    new = _with_band(model, band, y_new.value, point, rel)
    return decision("shrink", new, margin, why + below, note=note), new, sigma, worst


def _past(value: float, prediction: Prediction, is_max: bool) -> bool:
    """``value`` beyond the guarding edge of ``prediction``, past the solver's tolerance."""
    if is_max:
        return value > prediction.upper * (1 + EDGE_RTOL)
    return value < prediction.lower * (1 - EDGE_RTOL)


def _with_band(
    model: PowerLawModel,
    band: float,
    value: float,
    point: Mapping[str, float],
    rel: Mapping[str, float],
) -> PowerLawModel:
    """The model whose band at ``point`` is ``band`` (ΔK from the first-order law)."""
    if math.isclose(band, model.predict(point, rel).band, rel_tol=1e-12, abs_tol=0.0):
        return model  # unchanged: no round trip through floats, no new setpoint version
    setpoint_part = model.relative_band(rel) ** 2 - (model.dK / model.K) ** 2
    dK_over_K = math.sqrt(max((band / value) ** 2 - setpoint_part, 0.0))
    return replace(model, dK=model.K * dK_over_K)
