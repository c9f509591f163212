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
  points"). Either is flagged; the band grows to cover the reading (below): ``expand``.
- ``y − u`` above the limit but ``y − 3σ`` under it: the note ``past_limit`` (the part is out
  of tolerance by ISO 14253-1's decision rule [3]_), not an alarm (a process at its limit
  gives one in 44 parts; 3σ, one in 740). Under a band setpoint it is still ``above_band``.
- otherwise the margin law above; a reading whose ``y + u`` lies under the band's lower edge
  carries the note ``below_band`` (the model is pessimistic there), never a flag: a part that
  came out better than predicted is no reason to widen a band.
- a ``learn`` setpoint held by a cone is ``above_band`` only when ``y − 3σ`` is past the
  cone's edge; its fallback band still grows to cover the reading, unflagged.

A maximum's reading is read at the measuring chain's noise scales (:mod:`supervisor.rcb.
noise`; the reported ``u`` is a prior on the noise, not its value, DESIGN.md): where ``y + P u``
is past the limit, ``P`` the *prudent* scale (2.11 before any reading has shown the chain's
noise, 1 once it is as quiet as it says), the alarm reads ``y + P u``; a reading that shows the
process changed (``moved > 0``) reads ``y + Q u``, ``Q`` the *bound* scale (the chain's upper
``Φ(2)`` quantile, 3.15 before any reading): the band covered the old truth, not the new one.
A grown band's edge is run at the limit: it covers the reading at the margin's ``u + δ``
(below), at least ``P u``, up to ``Q u`` the further the reading lies over its prediction (past
``P u``: one reading in 140 under the noise prior's Student t, one in 13 from a chain 3x
noisier than it says; ``Q u``: one in 440 and 56). The floor and the alarm's 3σ read ``ŝ u``.

The margin of a reading over the prediction ``Y`` at its setpoint counts ``u + δ``, ``δ = y −
Y``, up to ``Q u``: ``M = Y_lim − (y + u + min(δ, (Q − 1) u))``; at or under the prediction the
paper's ``M = Y_lim − (y + u)`` (continuous at ``y = Y``). The next setpoint raises the truth by
about ``α M``, so a reading ``e`` under a truth ``d`` under the limit is safe while ``e ≤ u +
3 d``; under the prediction the band stands between the reading and the limit (``d ≥ ΔY −
e``), over it ``d`` may be near 0 and the unknown noise decides. Table 5 step 1 (3.06 ± 0.09
µm, under its prediction) keeps the paper's 0.85 µm; step 2 (1.82 ± 0.07 µm, 0.098 µm over,
the chain's noise not yet known) takes 2.0 − (1.82 + 0.07 + 0.098) = 0.012 µm, the paper 0.11
(``y + P u`` = 1.97 µm is under the limit). ``ivester``, all five faults, 1000 x 30 parts: 28
avoidable crossings with ``y + u``, 0 now.

Minima (tool life) mirror it at the reported u: ``M = (y − u) − Y_lim``, breach, below_band.
With tool wear (an operation with a ``parts_per_edge`` limit, a report giving the edge's age),
a rising quantity's margin is taken from the reading projected to the edge's last part, ``M =
Y_lim − (y↑ + u)`` (:mod:`supervisor.rcb.wear`); flags, notes and the cover rule stay on the
reading itself. ``ΔY'`` is stored as a new ``ΔK`` through the first-order law of :func:`models.
powerlaw.relative_band`: ``ΔK'/K = sqrt((ΔY'/Y)² − Σ(e_i Δx_i/x_i)²)``.

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
from dataclasses import dataclass, replace

from models import quantities
from models.errors import InputError
from models.powerlaw import PowerLawModel, Prediction
from models.quantities import MODEL_QUANTITIES
from supervisor.inputs.part_report import COVERAGE_FACTOR, Measurement, ToolWear
from supervisor.inputs.plan import Operation
from supervisor.optimize.result import OperationResult
from supervisor.optimize.solve import RECHECK_RTOL
from supervisor.rcb.decision import Action, Decision, Flag, Note
from supervisor.rcb.state import RcbSettings, RcbState, prior_sigma

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
    bound_u: float = 0.0,
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
    ``alarm_u`` and ``bound_u``: the reading's ``u`` at the chain's prudent scale ``P`` and at
    its bound scale ``Q`` (module docstring; 0: the reading's own ``u``).

    Raises
    ------
    InputError
        When the measurement drives the band past what a float holds (an overflow), naming
        the operation's measured quantity.
    """
    try:
        return _apply_law(
            state, operation, result, quantity, measurement, projection, moved, alarm_u, bound_u
        )
    except ArithmeticError:
        where = f"operations.{operation.name}.measurements.{quantity}"
        raise InputError(where, measurement.value, _OUT_OF_RANGE) from None


@dataclass(frozen=True)
class _Case:
    """One reading of one quantity at the setpoint a part was made with, and its decision."""

    operation: Operation
    quantity: str
    model: PowerLawModel  # before the reading
    point: Mapping[str, float]
    rel: Mapping[str, float]
    predicted: Prediction  # the model's at the point
    shown: Prediction  # the prediction the part was made with (a cone's for learn)
    y: float
    u: float
    limit: float | None
    is_max: bool

    def decision(
        self,
        action: Action,
        new: PowerLawModel,
        margin: float | None,
        why: str,
        flag: Flag | None = None,
        note: Note | None = None,
    ) -> Decision:
        return Decision(
            operation=self.operation.name,
            quantity=self.quantity,
            action=action,
            margin=margin,
            band_before=self.predicted.band,
            band_after=new.predict(self.point, self.rel).band,
            dK_before=self.model.dK,
            dK_after=new.dK,
            K_before=self.model.K,
            K_after=new.K,
            predicted=self.shown.value,
            measured=self.y,
            uncertainty=self.u,
            limit=self.limit,
            flagged=flag is not None,
            reason=why,
            flag=flag,
            note=note,
        )


def _apply_law(
    state: RcbState,
    operation: Operation,
    result: OperationResult,
    quantity: str,
    measurement: Measurement,
    projection: float,
    moved: float,
    alarm_u: float,
    bound_u: float,
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
    case = _Case(operation, quantity, model, point, rel, predicted, shown, y, u, limit, is_max)
    # the side of the measurement that guards the limit, and the band's edges in that sense
    guard = y + u if is_max else max(y - u, 0.0)
    # the most demanding measurement so far, as a K-equivalent (RcbState.seen)
    shape = predicted.value / model.K  # Π x_i^e_i at the part's setpoint
    edge_now = guard / shape
    before = state.seen.get((operation.name, quantity), edge_now)
    worst = max(before, edge_now) if is_max else min(before, edge_now)
    if limit is None:
        return case.decision("hold", model, None, "no limit on this quantity"), model, sigma, worst
    # u at the chain's scales (module docstring): the alarm's, the margin's and a grown band's
    read = _noise_read(y, u, shown.value, limit, alarm_u, bound_u, moved)
    wide, margin_u, cover_u = read if is_max else (u, u, u)
    alarm = y + wide if is_max else guard
    # the margin the edge will still have at its last part (wear, supervisor.rcb.wear)
    margin = limit - (y * projection + margin_u) if is_max else guard - limit
    flag, note, fallback_only = _flags(case, result, limit, alarm, guard)
    model, sigma = settings.rule.adjust(
        model, point, Measurement(y, max(u, bound_u)), sigma, settings.coverage_k, settings.tau
    )
    y_new = model.predict(point, rel).value
    # the band keeps covering every measurement so far: K(1 ± ΔY/Y) reaches the worst one
    cover = (worst / model.K - 1.0 if is_max else 1.0 - worst / model.K) * y_new
    if flag is not None or fallback_only:  # a grown band covers the reading (module docstring)
        grown = max(alarm, y + cover_u) if is_max else alarm
        reach = grown - y_new if is_max else y_new - grown
        if moved > 0 and is_max and alarm > limit:  # a change: the back-off's exponent error
            reach = alarm * (alarm / limit) ** (settings.coverage_k * moved) - y_new
        new = _with_band(model, max(predicted.band, reach, cover), y_new, point, rel)
        why = _grown_why(case, result, flag, grown - y if is_max else wide)
        action: Action = "expand" if new.predict(point, rel).band > predicted.band else "hold"
        return case.decision(action, new, margin, why, flag, note), new, sigma, worst
    worn = is_max and projection > 1.0
    projected = f"reading projected {100 * (projection - 1):+.3g} % for wear" if worn else ""
    decided, new = _shrunk(case, settings, model, sigma, y_new, margin, cover, projected, note)
    return decided, new, sigma, worst


def _noise_read(
    y: float, u: float, y_hat: float, limit: float, alarm_u: float, bound_u: float, moved: float
) -> tuple[float, float, float]:
    """A maximum's ``u`` for the alarm, for the margin and for a grown band (module docstring).

    ``P u`` where ``y + P u`` is past the limit, ``Q u`` for a change; the margin's ``u + δ``
    over the prediction ``y_hat`` up to ``Q u``; a grown band's the margin's, at least ``P u``.
    """
    prudent_u = max(u, alarm_u)
    bound_u = max(prudent_u, bound_u)
    wide = prudent_u if y + alarm_u > limit else u
    if moved > 0:  # a change: the band covered the old truth, not the new one
        wide = bound_u
    margin_u = u + min(max(y - y_hat, 0.0), bound_u - u)
    return wide, margin_u, max(prudent_u, margin_u)


def _flags(
    case: _Case, result: OperationResult, limit: float, alarm: float, guard: float
) -> tuple[Flag | None, Note | None, bool]:
    """The reading's flag and note, and whether only a cone's fallback band must grow."""
    y, u, is_max, shown = case.y, case.u, case.is_max, case.shown
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
    fallback_only = result.robust_by == "cone" and _past(alarm, case.predicted, is_max)
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
    return flag, note, fallback_only


def _grown_why(case: _Case, result: OperationResult, flag: Flag | None, wide: float) -> str:
    """Why a band grows: its flag and the side of the reading it covers."""
    if flag is None:
        return "inside the learned cone; the fallback band grows to cover it"
    is_max = case.is_max
    if flag == "breach":
        where = f"measured {'−' if is_max else '+'} {ALARM_SIGMA:g}σ past the limit"
    elif result.robust_by == "cone":
        where = f"measured {'−' if is_max else '+'} {ALARM_SIGMA:g}σ past the cone"
    else:
        times = f"{wide / case.u:.3g} " if wide > case.u else ""  # the cover's scale
        where = f"measured {'+' if is_max else '−'} {times}u {flag}"
    return f"{where}: never shrink; band covers it"


def _shrunk(
    case: _Case,
    settings: RcbSettings,
    model: PowerLawModel,
    sigma: float,
    y_new: float,
    margin: float,
    cover: float,
    projected: str,
    note: Note | None,
) -> tuple[Decision, PowerLawModel]:
    """An unflagged reading: the margin law, the floor and the cover of every reading so far."""
    point, rel, band_before = case.point, case.rel, case.predicted.band
    floor = settings.floors.get(case.quantity, case.u)
    pessimistic = note in ("below_band", "above_band")
    below = " (note: past the band's other edge: the model is pessimistic)" if pessimistic else ""
    if margin <= 0:
        new = _with_band(model, max(band_before, cover), y_new, point, rel)
        why = "no margin: measured + u at the limit"
        if projected:
            why = f"no margin left at the edge's last part ({projected})"
        return case.decision("hold", new, margin, why, note=note), new
    band = max(band_before - settings.alpha * margin, floor)
    band = settings.rule.least_band(band, sigma, y_new, settings.coverage_k, settings.tau)
    at = f" at the edge's last part ({projected})" if projected else ""
    why = f"margin {margin:.4g} > 0{at}: band shrinks by {settings.alpha:g} of it"
    why += f" (floor {floor:.4g})"
    if cover > band:
        band = cover
        why = "margin > 0, but the band keeps covering the most demanding measurement so far"
    if band >= band_before or math.isclose(band, band_before, rel_tol=1e-12):
        new = _with_band(model, band_before, y_new, point, rel)
        return case.decision("hold", new, margin, "band at its floor" + below, note=note), new
    new = _with_band(model, band, y_new, point, rel)
    return case.decision("shrink", new, margin, why + below, note=note), new


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
