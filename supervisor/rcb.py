r"""Recursive Constraint Bounding: shrink a model's band where a part shows room to spare.

For each operation and each measured constrained quantity, at the setpoint the part was made
with (Ivester & Heigel, "Adaptive Control Optimization"; DESIGN.md, "RCB"):

.. math::

    M = Y_{lim} - (y + u), \qquad
    \Delta Y' = \max(\Delta Y - \alpha M, \; \Delta Y_{floor}) \quad (M > 0)

with ``α = 0.25`` ("one or more of the uncertainty parameters is reduced by a fraction (0.25) of
the difference"). A measurement outside the predicted band ``Y ± ΔY`` or over the limit never
shrinks the band: it grows to ``|y − Y| + u`` so it covers the measurement, and the decision is
flagged. ``ΔY'`` is stored as a new ``ΔK`` through the first-order law of
:func:`models.powerlaw.relative_band`:
``ΔK'/K = sqrt((ΔY'/Y)² − Σ(e_i Δx_i/x_i)²)``. For a minimum (tool life) the sides swap:
``M = (y − u) − Y_lim``.

Two strategies:

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
from models.powerlaw import PowerLawModel
from models.quantities import MODEL_QUANTITIES
from models.tool import Tool
from supervisor.optimizer import OperationResult, PlanResult, optimize_plan
from supervisor.plan import PARTS_PER_EDGE, Operation, Plan
from supervisor.report import Measurement, PartReport, ToolWear

Strategy = Literal["ivester", "bayes"]
Action = Literal["shrink", "hold", "expand"]
STRATEGIES: tuple[Strategy, ...] = ("ivester", "bayes")


@dataclass(frozen=True)
class RcbSettings:
    """How bands are updated.

    Parameters
    ----------
    strategy : {"ivester", "bayes"}
        ``ivester``: the paper's law on ΔK; ``bayes``: also learn K (module docstring).
    alpha : float
        Fraction of the margin by which a band shrinks, ``0 < alpha <= 1`` (paper: 0.25).
    floors : Mapping[str, float]
        Least band ``ΔY`` per quantity, in its unit; default: the measurement's uncertainty.
    coverage_k : float
        ``bayes``: the band is ``k σ`` of ``ln K`` (2: the paper's ±2σ).
    discrepancy : float
        ``bayes``: ``τ``, the model discrepancy added to ``σ`` before each observation [-].
    """

    strategy: Strategy = "ivester"
    alpha: float = 0.25
    floors: Mapping[str, float] = field(default_factory=dict)
    coverage_k: float = 2.0
    discrepancy: float = 0.02

    def __post_init__(self) -> None:
        if self.strategy not in STRATEGIES:
            raise InputError("strategy", self.strategy, f"expected one of: {', '.join(STRATEGIES)}")
        if not (0 < self.alpha <= 1):
            raise InputError("alpha", self.alpha, "must be in (0, 1]")
        for quantity, floor in self.floors.items():
            if quantity not in MODEL_QUANTITIES:
                raise InputError(f"floors.{quantity}", floor, "unknown quantity")
            if not (math.isfinite(floor) and floor >= 0):
                raise InputError(f"floors.{quantity}", floor, "must be a number >= 0")
        if not (self.coverage_k > 0 and self.discrepancy >= 0):
            raise InputError("coverage_k", self.coverage_k, "must be > 0 (discrepancy >= 0)")


@dataclass(frozen=True)
class Decision:
    """What one measurement did to one band.

    ``margin`` is ``limit − (measured + u)`` for a maximum and ``(measured − u) − limit`` for
    a minimum (``margin`` and ``limit`` are ``None`` for a quantity without a limit);
    ``band_*`` are ``ΔY`` at the setpoint the part was made with; ``flagged`` marks a
    measurement outside the band or past the limit.
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
        The current robust optimum under those models.
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
    """

    plan: Plan
    tools: Mapping[str, Tool]
    setpoints: PlanResult
    version: int
    settings: RcbSettings
    sigma: Mapping[tuple[str, str], float] = field(default_factory=dict)
    seen: Mapping[tuple[str, str], float] = field(default_factory=dict)


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
        The new state and one decision per measurement.

    Raises
    ------
    InputError
        Unknown operation or quantity, or a setpoint version the state does not hold; nothing
        is applied.
    InfeasibleError
        The grown bands leave no safe setpoint (the operation must stop).
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
    for name, quantity, measurement in measured_items:
        key = (name, quantity)
        decision, model, sigma[key], seen[key] = _apply(
            state, operations[name], results[name], quantity, measurement
        )
        decisions.append(decision)
        tools[name] = _with_model(tools[name], model)
    if tools == dict(state.tools):
        return replace(state, sigma=sigma, seen=seen), tuple(decisions)
    new = replace(
        state,
        tools=tools,
        setpoints=optimize_plan(state.plan, tools, previous=(state.setpoints, state.tools)),
        version=state.version + 1,
        sigma=sigma,
        seen=seen,
    )
    return new, tuple(decisions)


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
    """The law for one measured quantity: decision, new model, new σ of ln K, new ``seen``."""
    settings = state.settings
    model = state.tools[operation.name].models[quantity]
    sigma = state.sigma.get((operation.name, quantity), prior_sigma(model, settings))
    point = {**result.setpoint, **operation.context}
    rel = operation.setpoint_rel_uncertainty
    predicted = model.predict(point, rel)
    y, u = measurement.value, measurement.uncertainty
    limit = _limit(operation, quantity)
    sense = MODEL_QUANTITIES[quantity].sense
    floor = settings.floors.get(quantity, u)

    def decision(
        action: Action, new: PowerLawModel, margin: float | None, flag: bool, why: str
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
            predicted=predicted.value,
            measured=y,
            uncertainty=u,
            limit=limit,
            flagged=flag,
            reason=why,
        )

    # the most demanding measurement so far, as a K-equivalent (RcbState.seen)
    shape = predicted.value / model.K  # Π x_i^e_i at the part's setpoint
    edge_now = (y + u) / shape if sense == "max" else max(y - u, 0.0) / shape
    before = state.seen.get((operation.name, quantity), edge_now)
    worst = max(before, edge_now) if sense == "max" else min(before, edge_now)
    if limit is None:
        hold = decision("hold", model, None, False, "no limit on this quantity")
        return hold, model, sigma, worst
    margin = limit - (y + u) if sense == "max" else (y - u) - limit
    past_limit = y > limit if sense == "max" else y < limit
    outside = abs(y - predicted.value) > predicted.band

    # bayes: conjugate update of ln K first; the band law then acts around the new K
    if settings.strategy == "bayes" and y > 0:
        model, sigma = _bayes(model, point, measurement, sigma, settings)
    y_new = model.predict(point, rel)
    # the band keeps covering every measurement so far: K(1 ± ΔY/Y) reaches the worst one
    cover = (worst / model.K - 1.0 if sense == "max" else 1.0 - worst / model.K) * y_new.value
    if past_limit or outside:
        band = max(predicted.band, abs(y - y_new.value) + u, cover)
        new = _with_band(model, band, y_new.value, point, rel)
        why = "measurement past the limit" if past_limit else "measurement outside the band"
        action: Action = "expand" if new.predict(point, rel).band > predicted.band else "hold"
        flagged = decision(action, new, margin, True, f"{why}: never shrink; band covers it")
        return flagged, new, sigma, worst
    if margin <= 0:
        new = _with_band(model, max(predicted.band, cover), y_new.value, point, rel)
        no_margin = decision("hold", new, margin, False, "no margin: measured + u at the limit")
        return no_margin, new, sigma, worst
    band = max(predicted.band - settings.alpha * margin, floor)
    if settings.strategy == "bayes":
        # the band used at the next (different) setpoint is the predicted one: σ'² + τ²
        predicted_sigma = math.hypot(sigma, settings.discrepancy)
        band = max(band, settings.coverage_k * predicted_sigma * y_new.value)
    why = f"margin {margin:.4g} > 0: band shrinks by {settings.alpha:g} of it (floor {floor:.4g})"
    if cover > band:
        band = cover
        why = "margin > 0, but the band keeps covering the most demanding measurement so far"
    if band >= predicted.band or math.isclose(band, predicted.band, rel_tol=1e-12):
        new = _with_band(model, predicted.band, y_new.value, point, rel)
        return decision("hold", new, margin, False, "band at its floor"), new, sigma, worst
    new = _with_band(model, band, y_new.value, point, rel)
    return decision("shrink", new, margin, False, why), new, sigma, worst


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


def _bayes(
    model: PowerLawModel,
    point: Mapping[str, float],
    measurement: Measurement,
    sigma: float,
    settings: RcbSettings,
) -> tuple[PowerLawModel, float]:
    """Conjugate normal update of ``ln K`` (module docstring); returns model and new σ."""
    k = settings.coverage_k
    shape = model.predict(point).value / model.K  # Π x_i^e_i
    z = math.log(measurement.value) - math.log(shape)
    prior_var = sigma**2 + settings.discrepancy**2
    obs_var = max((measurement.uncertainty / k) / measurement.value, 1e-9) ** 2
    post_var = 1.0 / (1.0 / prior_var + 1.0 / obs_var)
    mu = post_var * (math.log(model.K) / prior_var + z / obs_var)
    K = math.exp(mu)
    return replace(model, K=K, dK=model.dK * K / model.K), math.sqrt(post_var)
