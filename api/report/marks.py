"""How a decision and a halt read to a person, the same in the CLI tables and the HTML report."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

#: How a flagged decision is shown at a glance, per flag (the band grew: never a note).
FLAG_LABELS = {"breach": "BREACH", "above_band": "ABOVE", "below_band": "BELOW"}
#: How a note is shown: information only, never an alarm (past_limit: the part is out of
#: tolerance by more than its ±u, within the noise's 3σ: supervisor.rcb.law).
NOTE_LABELS = {
    "below_band": "note: below band",
    "above_band": "note: above band",
    "past_limit": "note: past limit",
}


def decision_mark(d: Mapping[str, Any]) -> tuple[str, str]:
    """``(label, kind)`` of a decision's JSON: a breach, a reading past the band, or a note.

    ``kind`` names the CSS class (``breach``, ``above-band``, ``below-band``, ``note``); a
    decision stored before flags were kept apart (flagged, no ``flag``) is ``FLAG``/``flagged``;
    neither flag nor note: ``("", "")``.
    """
    flag, note = d.get("flag"), d.get("note")
    if flag in FLAG_LABELS:
        past = ", past limit" if note == "past_limit" else ""
        return FLAG_LABELS[flag] + past, flag.replace("_", "-")
    if d.get("flagged"):
        return "FLAG", "flagged"
    if note in NOTE_LABELS:
        return NOTE_LABELS[note], "note"
    return "", ""


def halt_lines(halt: Mapping[str, Any]) -> list[str]:
    """A halt (``plans.halt``) as lines: per operation, each limit and what it would need."""
    lines = []
    for o in halt.get("conflicts", []):
        for c in o["conflicts"]:
            needs = "needs a limit of at least" if c["sense"] == "max" else "can reach at most"
            sign = "<=" if c["sense"] == "max" else ">="
            lines.append(
                f"{o['operation']}: {c['name']} {sign} {c['limit']:.6g} {needs} {c['required']:.4g}"
            )
        if o.get("held_by"):
            lines.append(f"{o['operation']}: held by {', '.join(o['held_by'])}")
    return lines
