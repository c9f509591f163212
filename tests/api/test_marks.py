"""How a decision reads at a glance: a breach, a reading past the band, and the notes apart."""

from __future__ import annotations

from typing import get_args

import pytest

from api.report.marks import NOTE_LABELS, decision_mark, halt_cause, halt_lines
from supervisor.rcb.decision import Note


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
        # a reading too good to be true: a check for the operator, its own class
        (
            {"flag": None, "flagged": False, "note": "implausible_low"},
            ("CHECK SENSOR: implausibly low", "check"),
        ),
        (
            {"flag": None, "flagged": False, "note": "regime_change"},
            ("note: regime change", "note"),
        ),
        # the process changed and the new regime's first reading is past the band
        (
            {"flag": "above_band", "flagged": True, "note": "regime_change"},
            ("ABOVE, regime change", "above-band"),
        ),
        (
            {"flag": "breach", "flagged": True, "note": "regime_change"},
            ("BREACH, regime change", "breach"),
        ),
        ({"flag": None, "flagged": True, "note": None}, ("FLAG", "flagged")),  # stored before flags
        ({"flag": None, "flagged": False, "note": None}, ("", "")),
    ],
)
def test_decision_mark(decision, mark):
    assert decision_mark(decision) == mark


def test_every_note_has_a_label_that_fits_a_cli_cell_and_the_column():
    assert set(NOTE_LABELS) == set(get_args(Note))
    for note in get_args(Note):
        assert len(note) <= 20  # decisions.note is String(20)
        assert len(NOTE_LABELS[note]) <= 30  # the flag / note column of rcb parts at 80 columns


CONFLICT_HALT = {
    "message": "rough-od: infeasible",
    "conflicts": [
        {
            "operation": "rough-od",
            "message": "rough-od: infeasible",
            "conflicts": [{"name": "force_N", "limit": 2000.0, "required": 2110.4, "sense": "max"}],
            "held_by": ["depth_mm >= 0.5"],
        }
    ],
}
GROSS = (
    "rough-od force_N measured 6000 N is past its limit 2000 N by 200 % (more than halt_over "
    "25 %): an engineer must check the process and replan"
)
GROSS_HALT = {
    "message": GROSS,
    "conflicts": [{"operation": "rough-od", "message": GROSS, "conflicts": [], "held_by": []}],
}


def test_a_halt_with_conflicts_lists_each_limit_and_what_holds_it():
    assert halt_lines(CONFLICT_HALT) == [
        "rough-od: force_N <= 2000 needs a limit of at least 2110",
        "rough-od: held by depth_mm >= 0.5",
    ]
    assert halt_cause(CONFLICT_HALT) == "no setpoint meets the bands in force"


def test_a_halt_on_a_gross_breach_reads_as_its_message():
    assert halt_lines(GROSS_HALT) == [GROSS]
    assert halt_cause(GROSS_HALT) == (
        "a reading is past its limit by more than the plan's halt_over"
    )
    other = {"conflicts": [{**GROSS_HALT["conflicts"][0], "message": "force_N 6000 N"}]}
    assert halt_lines(other) == ["rough-od: force_N 6000 N"]  # the operation named once
    both = {"conflicts": CONFLICT_HALT["conflicts"] + GROSS_HALT["conflicts"]}
    assert halt_lines(both)[-1] == GROSS and "halt_over" in halt_cause(both)
    assert halt_lines({"message": "halted", "conflicts": []}) == ["halted"]
