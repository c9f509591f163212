"""The decisions of the shop-floor rules: a quarantined reading, a change, a gross breach.

DESIGN.md, RCB, "The shop floor misbehaves": :mod:`supervisor.rcb.monitor` judges a reading;
this module says what the decision of such a reading reads, and when a reading halts the plan.
"""

from __future__ import annotations

from dataclasses import replace

from models.quantities import MODEL_QUANTITIES
from supervisor.inputs.part_report import Measurement
from supervisor.inputs.plan import Operation
from supervisor.rcb.decision import Decision
from supervisor.rcb.law import limit_of
from supervisor.rcb.monitor import Watched
from supervisor.rcb.state import HaltedOperation


def quarantined(law: Decision, sigma: float) -> Decision:
    """The decision of a quarantined reading: nothing moves, the operator is told.

    ``law``: what the band law would have made of the reading (its margin and band are shown
    as they stand); ``sigma``: how far under what was expected the reading is, in σ.
    """
    return replace(
        law,
        action="hold",
        band_after=law.band_before,
        dK_after=law.dK_before,
        K_after=law.K_before,
        flagged=False,
        flag=None,
        note="implausible_low",
        reason=(
            f"implausibly low: {-sigma:.3g}σ under what the model and its scatter allow "
            "(check the sensor and the tool); not learned from until the next reading "
            "confirms it"
        ),
    )


def changed(decision: Decision, watched: Watched, common: float | None = None) -> Decision:
    """The decision of a reading that shows the process changed (note ``regime_change``).

    ``common``: Stouffer's ``Z`` of the quantity over the part's operations when they moved
    together (:mod:`supervisor.rcb.common_cause`).
    """
    if watched.verdict == "confirm":
        why = "regime change: the reading confirms the low one before it; both learned"
    elif common is not None:
        why = (
            f"regime change: this quantity rose in the part's operations together "
            f"({common:.3g}σ pooled; this reading {watched.sigma:+.3g}σ); old evidence "
            "discounted"
        )
    else:
        why = f"regime change: {watched.sigma:.3g}σ over what was expected; old evidence discounted"
    # a part out of tolerance keeps its note (the quality department's); the reason says both
    note = decision.note if decision.note == "past_limit" else "regime_change"
    return replace(decision, note=note, reason=f"{why}; {decision.reason}")


def own_flags(shifted: Decision, own: Decision) -> Decision:
    """The decision of a reading learned at its part's common shift, flagged on the reading.

    ``shifted``: the law's decision on the shift the part's other operations showed
    (:mod:`supervisor.rcb.common_cause`), whose upper edge was above the reading's, with the
    shift's wide ``u``; ``own``: the law's on the reading itself. The band and the margin are
    the shift's (the higher); the flag and the note are the reading's: judged at the shift's
    ``u``, a reading of 2600 N against a 1500 N limit was no breach ("inside the learned
    cone"), and the parts and the report said it crossed nothing.
    """
    if (own.flag, own.note) == (shifted.flag, shifted.note):
        return shifted
    action = "hold" if own.flagged and shifted.action == "shrink" else shifted.action
    why = shifted.reason
    if own.flagged:
        why = f"{own.reason}; the band covers the shift the part's other operations showed"
    return replace(
        shifted, action=action, flag=own.flag, flagged=own.flagged, note=own.note, reason=why
    )


def gross_breach(
    operation: Operation, quantity: str, measurement: Measurement, halt_over: float
) -> HaltedOperation | None:
    """What halts the plan when the reading is past its limit by more than ``halt_over``.

    For a maximum ``y − u > (1 + halt_over) · limit``, for a minimum ``y + u < (1 − halt_over)
    · limit`` (``u`` at the measured noise scale): beyond its uncertainty, as an adaptive
    control's extreme limit stops the spindle whatever the controller could still do.
    """
    limit = limit_of(operation, quantity)
    if limit is None or limit <= 0:
        return None
    y, u = measurement.value, measurement.uncertainty
    if MODEL_QUANTITIES[quantity].sense == "max":
        sign, edge = "-", y - u
        past = edge / limit - 1.0
    else:
        sign, edge = "+", y + u
        past = 1.0 - edge / limit
    if past <= halt_over:
        return None
    message = (
        f"{operation.name} {quantity} measured {y:.6g} {sign} {u:.3g} = {edge:.6g} is past its "
        f"limit {limit:.6g} by {100 * past:.1f} % (more than halt_over "
        f"{100 * halt_over:.3g} %): an engineer must check the process and replan"
    )
    return HaltedOperation(operation.name, (), (), message)
