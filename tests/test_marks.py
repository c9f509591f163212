"""How a decision reads at a glance: a breach, a reading past the band, and the notes apart."""

from __future__ import annotations

import pytest

from api.report.marks import decision_mark


@pytest.mark.parametrize(
    ("decision", "mark"),
    [
        ({"flag": "breach", "flagged": True, "note": None}, ("BREACH", "breach")),
        ({"flag": "above_band", "flagged": True, "note": None}, ("ABOVE", "above-band")),
        # a band setpoint's reading past the limit by more than u, within its 3σ
        (
            {"flag": "above_band", "flagged": True, "note": "past_limit"},
            ("ABOVE, past limit", "above-band"),
        ),
        # a cone setpoint's: information, not an alarm
        ({"flag": None, "flagged": False, "note": "past_limit"}, ("note: past limit", "note")),
        ({"flag": None, "flagged": False, "note": "below_band"}, ("note: below band", "note")),
        ({"flag": None, "flagged": True, "note": None}, ("FLAG", "flagged")),  # stored before flags
        ({"flag": None, "flagged": False, "note": None}, ("", "")),
    ],
)
def test_decision_mark(decision, mark):
    assert decision_mark(decision) == mark
