"""How a decision and a halt read to a person, the same in the CLI tables and the HTML report."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from supervisor.errors import Conflict

#: How a flagged decision is shown at a glance, per flag (the band grew: never a note).
FLAG_LABELS = {"breach": "BREACH", "above_band": "ABOVE", "below_band": "BELOW"}
#: How a note is shown: information only, never a flag (past_limit: the part is out of
#: tolerance by more than its ±u, within the noise's 3σ: supervisor.rcb.law; implausible_low:
#: a reading quarantined as too good to be true, worded as the check it asks for;
#: regime_change: the process changed and is being re-learned). Keys: supervisor.rcb.state.Note.
NOTE_LABELS = {
    "below_band": "note: below band",
    "above_band": "note: above band",
    "past_limit": "note: past limit",
    "implausible_low": "CHECK SENSOR: implausibly low",
    "regime_change": "note: regime change",
}
#: The CSS class of a note's mark (default ``note``): a note that asks the operator to act,
#: not to read (implausible_low: check the sensor and the tool), is shown as such.
NOTE_KINDS = {"implausible_low": "check"}
#: The notes a flag's label carries after it (``ABOVE, past limit``).
FLAG_NOTES = {"past_limit": "past limit", "regime_change": "regime change"}


def decision_mark(d: Mapping[str, Any]) -> tuple[str, str]:
    """``(label, kind)`` of a decision's JSON: a breach, a reading past the band, or a note.

    ``kind`` names the CSS class (``breach``, ``above-band``, ``below-band``, ``note``, and
    ``check`` for a note that asks for a sensor or tool check, :data:`NOTE_KINDS`); a flag's
    label carries the notes of :data:`FLAG_NOTES` after it (``ABOVE, regime change``); a
    decision stored before flags were kept apart (flagged, no ``flag``) is ``FLAG``/``flagged``;
    neither flag nor note: ``("", "")``.
    """
    flag, note = d.get("flag"), d.get("note")
    if flag in FLAG_LABELS:
        after = f", {FLAG_NOTES[note]}" if note in FLAG_NOTES else ""
        return FLAG_LABELS[flag] + after, flag.replace("_", "-")
    if d.get("flagged"):
        return "FLAG", "flagged"
    if note in NOTE_LABELS:
        return NOTE_LABELS[note], NOTE_KINDS.get(note, "note")
    return "", ""


def halt_cause(halt: Mapping[str, Any]) -> str:
    """Why a plan halted, in a few words: the bands leave no setpoint, or a gross breach."""
    operations = halt.get("conflicts", [])
    causes = []
    if not operations or any(o.get("conflicts") for o in operations):
        causes.append("no setpoint meets the bands in force")
    if any(not o.get("conflicts") for o in operations):
        causes.append("a reading is past its limit by more than the plan's halt_over")
    return "; ".join(causes)


def halt_lines(halt: Mapping[str, Any]) -> list[str]:
    """A halt (``plans.halt``) as lines: per operation, each limit and what it would need.

    An operation halted without conflicts (a reading past its limit by more than the plan's
    ``halt_over``) is its message; a halt with no operations at all, the halt's message.
    """
    lines = []
    operations = halt.get("conflicts", [])
    for o in operations:
        if not o.get("conflicts"):
            message = str(o.get("message") or "halted")
            prefix = "" if message.startswith(f"{o['operation']}") else f"{o['operation']}: "
            lines.append(prefix + message)
            continue
        for c in o["conflicts"]:
            conflict = Conflict(c["name"], c["limit"], c["required"], c["sense"])
            lines.append(f"{o['operation']}: {conflict.describe()}")
        if o.get("held_by"):
            lines.append(f"{o['operation']}: held by {', '.join(o['held_by'])}")
    if not operations and halt.get("message"):
        lines.append(str(halt["message"]))
    return lines
