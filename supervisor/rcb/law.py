r"""The band law of Recursive Constraint Bounding, for one measured quantity of one part.

For each operation and each measured constrained quantity, at the setpoint the part was made
with (Ivester & Heigel, "Adaptive Control Optimization"; DESIGN.md, "RCB"):

.. math::

    M = Y_{lim} - (y + u), \qquad
    \Delta Y' = \max(\Delta Y - \alpha M, \; \Delta Y_{floor}) \quad (M > 0)

with ``α = 0.25`` ("one or more of the uncertainty parameters is reduced by a fraction (0.25) of
the difference"). The law is one-sided, as the paper's: only the side of the band that guards
the limit matters. For a maximum:

- ``y − 3σ`` above the limit (``σ = u/2``, ``u`` an expanded uncertainty at ``k = 2``):
  ``breach``, the process crossed the limit beyond what the reading's noise explains (a
  Shewhart 3σ control limit [4]_); else ``y + u`` above the band's upper edge ``Y + ΔY``:
  ``above_band`` (the band must cover measured + u, as the paper's bands "encompass all of the
  points"). Either is flagged and the band grows to ``y + u − Y`` so it covers the measurement
  (action ``expand``); it never shrinks then.
- ``y − u`` above the limit but ``y − 3σ`` under it: the note ``past_limit`` (the part is out
  of tolerance by ISO 14253-1's decision rule [3]_, the quality department's call), not an
  alarm. A process run at its limit gives such a reading once in 44 parts from noise alone
  (DESIGN.md's ``y + u`` rule: once in 2), and 3σ once in 740. Under a band setpoint the
  band's edge is at or under the limit, so such a reading is still ``above_band`` and backs off.
- otherwise the margin law above; a reading whose ``y + u`` lies under the band's lower edge
  carries the note ``below_band`` (the model is pessimistic there), never a flag: a part that
  came out better than predicted is no reason to widen a band.
- a ``learn`` setpoint held by a cone (which bounds the true value, not a measurement) is
  ``above_band`` only when ``y − 3σ`` is past the cone's edge; its fallback band still grows
  to cover ``y + u``, unflagged.

A maximum's reading whose ``y + P u`` is past the limit, ``P`` the measuring chain's *prudent*
noise scale (:attr:`supervisor.rcb.noise.NoiseScale.prudent_scale`: 2.11 before any reading has
shown the chain's noise, 1 once the chain has shown it is as quiet as it says), is checked
against the band's edge at ``y + P u``, and a band it grows covers ``y + P u``; the floor and the
``breach`` alarm read ``u`` at the measured ``ŝ``, and a reading whose ``y + P u`` is under the
limit is the paper's. The reported ``u`` is a prior on the noise, not its value (DESIGN.md): a
chain 3x noisier than it claims (``σ = 1.5 u``) reads more than ``u`` under the truth once in 4
parts, and the paper's ``y + u`` then lets a band shrink whose edge the truth already crosses (a
catalogue band does not cover a truth that is a power law only locally). Only near the limit: a
band at its floor (``ΔY = u``) would otherwise flag every reading on the model before the
chain's noise is known.

The margin of a maximum's reading over the prediction ``Y`` at its setpoint counts its noise
as ``u + δ``, ``δ = y − Y``, up to ``P u``: ``M = Y_lim − (y + u + min(δ, (P − 1) u))``; at or
under the prediction the paper's ``M = Y_lim − (y + u)`` (continuous at ``y = Y``: a reading
rounded a hair over its prediction keeps the paper's margin within that hair). Why: the next
setpoint raises the truth by about ``α M``, so a reading ``e`` under a truth ``d`` under the
limit is safe while ``e ≤ u + 3 d`` (α = 0.25). Under the prediction the band itself stands
between the reading and the limit, ``d ≥ ΔY − e``, and every ``e ≤ (u + 3 ΔY)/4`` is safe; the
further over it, the nearer ``d`` may be to 0 (a truth the catalogue band barely covers), and
the more the reading's unknown noise decides. Ivester & Heigel's Table 5 step 1 (rough-od Ra
3.06 ± 0.09 µm under its prediction) keeps the paper's margin, 0.85 µm; step 2 (rough-grooves
Ra 1.82 ± 0.07 µm, 0.10 µm over its prediction, before any reading has shown the chain's
noise) takes 2.0 − (1.82 + 2.11 × 0.07) = 0.032 µm where the paper takes 0.11: its band
shrinks by 0.008 µm, not 0.028, until the chain shows it is as quiet as it says. A minimum
(tool life) keeps its ``u`` throughout: no monitor learns its noise, so ``P`` would stay the
prior's for ever. Measured on ``benchmarks/closed_loop.py``, ``ivester``, 1000 scenarios x 30
parts, all five faults: 28 avoidable crossings with the paper's ``y + u``, 11 with ``y + P u``
at the alarm and the cover, 9 with an unread common change backing off by its exponent error,
2 with the margin over the prediction too (the same 2 with ``P u`` at once over the
prediction, discontinuous); fault-free MRR/oracle after 10 parts 0.9462, 0.9460, 0.9454;
``learn`` fault-free unchanged (0.9801, p5 0.9729, 0.9925). ``P`` at the chain's ``Φ(2)``
quantile (3.15 before any reading) gave 1 but is not used: Table 5's step 2 reading would
then be flagged and back off where the paper shrinks (``y + P u`` stays under its 2.0 µm
limit only for ``P`` under 2.57).

Minima (tool life) mirror this: ``M = (y − u) − Y_lim``, a flag ``breach`` (``y + 3σ`` under
the limit) or ``below_band`` (``y − u`` under the lower edge), the notes ``past_limit`` and
``above_band``.
With tool wear (an operation with a ``parts_per_edge`` limit, a report giving the edge's age),
the margin of a rising quantity is taken from the reading projected to the edge's last part,
``M = Y_lim − (y↑ + u)`` with ``y↑`` of :mod:`supervisor.rcb.wear` (the rise per part learned
from the edge's readings): a new edge's margin is not the worn edge's. Flags, notes and the
cover rule stay on the reading itself.
``ΔY'`` is stored as a new ``ΔK`` through the first-order law of
:func:`models.powerlaw.relative_band`: ``ΔK'/K = sqrt((ΔY'/Y)² − Σ(e_i Δx_i/x_i)²)``.

References
----------
.. [1] Ivester & Heigel (NIST), "Adaptive Control Optimization" and Table 5.
.. [2] Ivester, Danai & Malkin (1997), "Cycle-Time Reduction in Machining by Recursive
   Constraint Bounding", ASME J. Manuf. Sci. Eng. 119(2).
.. [3] ISO 14253-1:2017, decision rules for conformity (the ``past_limit`` note).
.. [4] Montgomery, Introduction to Statistical Quality Control, 3σ control limits (the
   ``breach`` alarm: 0.135 % false alarms on one side).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

from models import quantities
from models.errors import InputError
from models.powerlaw import PowerLawModel, Prediction
from models.quantities import MODEL_QUANTITIES
from supervisor.inputs.part_report import COVERAGE_FACTOR, Measurement, ToolWear
from supervisor.inputs.plan import Operation
from supervisor.optimize.result import OperationResult
from supervisor.optimize.solve import RECHECK_RTOL
from supervisor.rcb.decision import Action, Decision, Flag, Note
from supervisor.rcb.state import RcbState, prior_sigma

#: A measurement is past a band's edge only beyond this fraction of it: an optimum sits on
#: its limit within the optimiser's re-check tolerance.
EDGE_RTOL = RECHECK_RTOL
#: A reading raises the alarm (``breach``, or past a cone) only when it is past the limit (the
#: cone's edge) by more than this many σ of its own noise: Shewhart's 3σ control limit, a false
#: alarm in 740 readings of a process exactly at its limit, against 1 in 44 at ±u (2σ).
ALARM_SIGMA = 3.0


def limit_of(operation: Operation, quantity: str) -> float | None:
    """The limit on ``quantity`` in its unit (a per-part limit times the volume), or None."""
    entry = quantities.quantity(quantity)
    given = operation.limits.get(entry.limit_name)
    if given is None or not entry.limit_per_volume:
        return given
    return given * operation.volume_mm3


def tool_life_measured(
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
    try:
        volume = wear.volume_mm3 * (allowable / vb) ** e_w
        return Measurement(volume, volume * abs(e_w) * wear.flank_wear_mm.uncertainty / vb)
    except (ArithmeticError, InputError):  # overflow: no edge wears that way
        where = f"operations.{operation.name}.tool_wear"
        raise InputError(where, vb, _OUT_OF_RANGE) from None


#: Why a measurement whose band or tool life overflows a float is refused.
_OUT_OF_RANGE = "out of the range the model can represent (a float overflows)"


def apply_law(
    state: RcbState,
    operation: Operation,
    result: OperationResult,
    quantity: str,
    measurement: Measurement,
    projection: float = 1.0,
    moved: float = 0.0,
    alarm_u: float = 0.0,
) -> tuple[Decision, PowerLawModel, float, float]:
    """The one-sided law for one measured quantity: decision, model, σ of ln K, ``seen``.

    ``projection``: ``y↑/y``, the reading's rise to its edge's last part
    (:meth:`supervisor.rcb.wear.WearRise.factor`); the margin is taken from ``y↑`` for a
    maximum (module docstring), flags and the cover rule from the reading itself.
    ``moved``: for a reading that shows the process changed
    (:mod:`supervisor.rcb.monitor`), the relative spread ``s`` of the model's exponents; a
    flagged reading's band then reaches ``(y + u)·(g/Y_lim)^(k s)``, ``g = y + u``: the next
    setpoint backs off by ``ln(g/Y_lim)`` in the quantity, and exponents wrong by ``k s`` of
    themselves would carry the reading that much higher there (the band moves the reading
    to another setpoint with the model's exponents).

    Raises
    ------
    InputError
        When the measurement drives the band past what a float holds (an overflow), naming
        the operation's measured quantity.
    """
    try:
        return _apply_law(
            state, operation, result, quantity, measurement, projection, moved, alarm_u
        )
    except ArithmeticError:
        where = f"operations.{operation.name}.measurements.{quantity}"
        raise InputError(where, measurement.value, _OUT_OF_RANGE) from None


def _apply_law(
    state: RcbState,
    operation: Operation,
    result: OperationResult,
    quantity: str,
    measurement: Measurement,
    projection: float,
    moved: float,
    alarm_u: float,
) -> tuple[Decision, PowerLawModel, float, float]:
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
    limit = limit_of(operation, quantity)
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
    # the side the alarm and a flagged band's cover read: ``u`` at the chain's prudent scale
    # the most demanding measurement so far, as a K-equivalent (RcbState.seen)
    shape = predicted.value / model.K  # Π x_i^e_i at the part's setpoint
    edge_now = guard / shape
    before = state.seen.get((operation.name, quantity), edge_now)
    worst = max(before, edge_now) if is_max else min(before, edge_now)
    if limit is None:
        hold = decision("hold", model, None, "no limit on this quantity")
        return hold, model, sigma, worst
    # u at the chain's prudent scale (module docstring): the alarm and a grown band read it
    # where that side is past the limit, the margin as far as the reading is over the prediction
    prudent_u = max(u, alarm_u)
    wide = prudent_u if is_max and y + alarm_u > limit else u
    alarm = y + wide if is_max else guard
    # the margin the edge will still have at its last part (wear, supervisor.rcb.wear)
    # over the prediction by δ, u + δ up to the prudent P u (module docstring)
    margin_u = u + min(max(y - shown.value, 0.0), prudent_u - u)
    margin = limit - (y * projection + margin_u) if is_max else guard - limit
    worn = is_max and projection > 1.0
    projected = f"reading projected {100 * (projection - 1):+.3g} % for wear" if worn else ""
    # the far side of the reading at the alarm's coverage: past the limit, the process crossed
    # it beyond what the reading's noise explains; at ±u only, the part is out of tolerance
    reach_u = ALARM_SIGMA / COVERAGE_FACTOR * u
    far_side = max(y - reach_u, 0.0) if is_max else y + reach_u
    iso_side = max(y - u, 0.0) if is_max else y + u
    if result.robust_by == "cone":  # a cone bounds the true value: the alarm's far side
        beyond_guard = _past(far_side, shown, is_max)
    else:  # a band covers measured ± u (Ivester & Heigel: "encompasses all of the points")
        beyond_guard = _past(alarm, shown, is_max)
    beyond_other = guard < shown.lower if is_max else guard > shown.upper
    # the fallback band of a cone setpoint: past its edge it grows, but is not flagged
    fallback_only = result.robust_by == "cone" and _past(alarm, predicted, is_max)
    flag: Flag | None = None
    if far_side > limit if is_max else far_side < limit:  # nonconformance proven
        flag = "breach"
    elif beyond_guard:
        flag = "above_band" if is_max else "below_band"
    note: Note | None = None
    if flag != "breach" and (iso_side > limit if is_max else iso_side < limit):
        note = "past_limit"  # ISO 14253-1 nonconformance of the part, not a process alarm
    elif beyond_other and flag is None:
        note = "below_band" if is_max else "above_band"

    rule = settings.rule
    model, sigma = rule.adjust(model, point, measurement, sigma, settings.coverage_k, settings.tau)
    y_new = model.predict(point, rel)
    # the band keeps covering every measurement so far: K(1 ± ΔY/Y) reaches the worst one
    cover = (worst / model.K - 1.0 if is_max else 1.0 - worst / model.K) * y_new.value
    if flag is not None or fallback_only:
        reach = alarm - y_new.value if is_max else y_new.value - alarm
        if moved > 0 and is_max and alarm > limit:  # a change: the back-off's exponent error
            reach = alarm * (alarm / limit) ** (settings.coverage_k * moved) - y_new.value
        new = _with_band(model, max(predicted.band, reach, cover), y_new.value, point, rel)
        action: Action = "expand" if new.predict(point, rel).band > predicted.band else "hold"
        if flag is None:
            why = "inside the learned cone; the fallback band grows to cover it"
            return decision(action, new, margin, why, note=note), new, sigma, worst
        if flag == "breach":
            where = f"measured {'−' if is_max else '+'} {ALARM_SIGMA:g}σ past the limit"
        elif result.robust_by == "cone":
            where = f"measured {'−' if is_max else '+'} {ALARM_SIGMA:g}σ past the cone"
        else:
            times = f"{wide / u:.3g} " if wide > u else ""  # the chain's prudent scale
            where = f"measured {'+' if is_max else '−'} {times}u {flag}"
        why = f"{where}: never shrink; band covers it"
        return decision(action, new, margin, why, flag, note), new, sigma, worst
    pessimistic = note in ("below_band", "above_band")
    below = " (note: past the band's other edge: the model is pessimistic)" if pessimistic else ""
    if margin <= 0:
        new = _with_band(model, max(predicted.band, cover), y_new.value, point, rel)
        why = "no margin: measured + u at the limit"
        if projected:
            why = f"no margin left at the edge's last part ({projected})"
        no_margin = decision("hold", new, margin, why, note=note)
        return no_margin, new, sigma, worst
    band = max(predicted.band - settings.alpha * margin, floor)
    band = rule.least_band(band, sigma, y_new.value, settings.coverage_k, settings.tau)
    at = f" at the edge's last part ({projected})" if projected else ""
    why = f"margin {margin:.4g} > 0{at}: band shrinks by {settings.alpha:g} of it"
    why += f" (floor {floor:.4g})"
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
    dK_over_K = math.sqrt(max((band / value) ** 2 - setpoint_part, 0.0))  # may overflow
    dK = model.K * dK_over_K
    if not math.isfinite(dK):
        raise OverflowError(f"ΔK = {dK} from a band of {band}")
    return replace(model, dK=dK)
