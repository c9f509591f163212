"""``rcb gcode`` refuses what it cannot rewrite safely, saying why (units, feed and spindle modes,
clamps, unreadable lines, ranges), and leaves alone, with a warning, what is not its setpoint
(thread leads, cycles' contours, tapping pitch, words outside a range).
"""

from __future__ import annotations

import math

import pytest
from gcode_support import DATA, SETPOINTS, assert_only_words_changed, program, refused, rewrite

from supervisor.gcode import BlockRange, GcodeError, OperationSetpoint, parse_range

# --------------------------------------------------------------------------------------------
# refusals


def test_refuses_an_f_word_without_a_feed_mode():
    err = refused(program("N1 G21 G96 S150 M03", "N2 G01 X10. F0.2"), "rough-od=N1:N2")
    assert err.field == "IN.nc line 2"
    assert err.value == "F0.2"
    assert "feed mode is not known" in err.reason and "no G94 or G95 before it" in err.reason


def test_refuses_an_s_word_without_a_spindle_mode():
    err = refused(program("N1 G21 G95", "N2 S150 M03", "N3 G01 X10. F0.2"), "rough-od=N1:N3")
    assert (err.field, err.value) == ("IN.nc line 2", "S150")
    assert "no G96 or G97 before it" in err.reason


@pytest.mark.parametrize(
    ("first", "reason"),
    [("N1 G95 G96", "no G20 or G21 before it"), ("N1 G20 G95 G96", "in inches (G20 at line 1)")],
)
def test_refuses_inches_or_an_unknown_unit_mode(first, reason):
    err = refused(program(first, "N2 S150 M03"), "rough-od=N1:N2")
    assert reason in err.reason


def test_refuses_inverse_time_feed():
    err = refused(program("N1 G21 G93 G96", "N2 G01 X10. F0.2"), "rough-od=N1:N2")
    assert "G93" in err.reason


def test_refuses_g98_g99_as_ambiguous_feed_modes():
    err = refused(program("N1 G21 G99 G96", "N2 G01 X10. F0.2"), "rough-od=N1:N2")
    assert "G99 at line 1" in err.reason and "system A" in err.reason
    # stated again after it: known
    rewrite(program("N1 G21 G99 G96", "N2 G95", "N3 G01 X10. F0.2"), "rough-od=N1:N3")


def test_refuses_g94_that_may_be_a_facing_cycle():
    err = refused(program("N1 G21 G95 G96", "N2 G94 X20. Z-2. F0.2"), "rough-od=N1:N2")
    assert "face-turning cycle" in err.reason
    rewrite(program("N1 G21 G95 G96", "N2 G94 G01 X20. Z-2. F200"), "rough-od=N1:N2")


def test_refuses_a_mode_set_in_an_optional_skip_block():
    text = program("N1 G21 G95 G96", "/N2 G94", "N3 G01 X10. F0.2")
    err = refused(text, "rough-od=N3:N3")
    assert "optional-skip (/) block" in err.reason and "line 2" in err.reason
    # the same mode again under block skip changes nothing
    rewrite(program("N1 G21 G95 G96", "/N2 G95", "N3 G01 X10. F0.2"), "rough-od=N3:N3")


def test_refuses_modes_after_a_subprogram_call_or_a_program_end():
    err = refused(
        program("N1 G21 G95 G96 S150 M03", "N2 M98 P1000", "N3 G01 X10. F0.2"), "rough-od=N3:N3"
    )
    assert "M98 at line 2 may have changed it" in err.reason
    err = refused(program("N1 G21 G95 G96", "N2 M30", "O2", "N3 G01 X10. F0.2"), "rough-od=N3:N3")
    assert "since program O2 at line 3" in err.reason


def test_refuses_a_clamp_below_the_speed_the_setpoint_needs():
    text = (DATA / "demo_g95_g96.nc").read_text().replace("G50 S3000", "G50 S1000")
    err = refused(text, "rough-od=N100:N180")
    assert err.field == "IN.nc line 9"
    assert "clamp S1000 (line 5) is below the 1061.0 rpm" in err.reason
    # enough for the finishing operation alone (1209 rpm > 1000: refused too)
    err = refused(text, "finish-od=N300:N350")
    assert "below the 1209.6 rpm" in err.reason


def test_refuses_a_clamp_lowered_later_in_the_range_and_under_g97():
    text = program("N1 G21 G95 G96 S150 M03", "N2 G01 X10. F0.2", "N3 G50 S900", "N4 Z-5.")
    assert "clamp S900 (line 3)" in refused(text, "rough-od=N1:N4").reason
    text = program("N1 G21 G95 G97 G50 S1000", "N2 S500 M03")
    assert "below the 1061.0 rpm" in refused(text, "rough-od=N1:N2").reason
    text = program("N1 G21 G95 G97 G50 S1100", "N2 S500 M03")
    assert [c.new for c in rewrite(text, "rough-od=N1:N2").changes] == ["S1061"]


@pytest.mark.parametrize(
    ("line", "problem"),
    [
        ("#100=0.3", "'#' at column 1"),
        ("N5 G01 X[#1+2.]", "'X' at column 8 is not followed by a number"),
        ("N5 IF [#1 GT 2] GOTO 10", "'I' at column 4 is not followed by a number"),
        ("N5 (OPEN COMMENT", "not closed"),
        ("N5 G01 X10. F0.2 F0.3", "two F words in one block"),
    ],
)
def test_refuses_unreadable_lines_before_the_end_of_the_last_range(line, problem):
    err = refused(program("N1 G21 G95 G96", line, "N10 S150 M03"), "rough-od=N10:N10")
    assert (err.field, err.value) == ("IN.nc line 2", line)
    assert problem in err.reason
    # after the last range they are left alone
    result = rewrite(program("N1 G21 G95 G96", "N10 S150 M03", line), "rough-od=N10:N10")
    assert result.text.endswith(line + "\n")


@pytest.mark.parametrize(
    ("maps", "reason"),
    [
        (["rough-od=N1:N99"], "no block N99 in the program"),
        (["rough-od=N2:N3"], "block N2 is on several lines (2, 4)"),
        (["rough-od=N3:N1"], "block N1 (line 1) comes before block N3 (line 3)"),
        (["rough-od=N1:N3", "finish-od=N3:N3"], "overlap rough-od=N1:N3 (lines 1-3)"),
        (["other=N1:N3"], "no setpoint for operation 'other'"),
    ],
)
def test_refuses_bad_ranges(maps, reason):
    text = program("N1 G21 G95 G96", "N2 S150 M03", "N3 G01 X10. F0.2", "N2 M30")
    err = refused(text, *maps)
    assert err.field == "map" and reason in err.reason


@pytest.mark.parametrize(
    "text", ["rough-od", "rough-od=N1", "=N1:N2", "rough-od=N1-N2", "op=Nx:N2"]
)
def test_parse_range_refuses_malformed_maps(text):
    with pytest.raises(GcodeError, match="OPERATION=N<start>:N<end>"):
        parse_range(text)


def test_parse_range():
    assert parse_range("rough-od=N100:N200") == BlockRange("rough-od", 100, 200)
    assert parse_range(" finish = 5 : n07 ") == BlockRange("finish", 5, 7)


def test_setpoints_must_be_positive_and_finite():
    with pytest.raises(GcodeError, match=r"op.feed_mm_rev = nan"):
        OperationSetpoint("op", feed_mm_rev=math.nan, speed_m_min=100, workpiece_diameter_mm=50)


# --------------------------------------------------------------------------------------------
# left alone, with a warning


def test_thread_lead_and_contour_of_a_roughing_cycle_are_left_alone():
    text = (DATA / "cycles.nc").read_text()
    thread = OperationSetpoint("thread", feed_mm_rev=0.2, speed_m_min=100, workpiece_diameter_mm=50)
    result = rewrite(
        text, "rough-od=N100:N190", "thread=N200:N240", setpoints={**SETPOINTS, "thread": thread}
    )
    assert [(c.line, c.old, c.new) for c in result.changes] == [
        (6, "S180", "S200"),
        (9, "F0.3", "F0.325"),  # the G71 block: the roughing feed
        (16, "S800", "S636"),  # 1000·100/(π·50) = 636.6 rpm
    ]
    messages = [(w.line, w.message) for w in result.warnings]
    assert (10, "F0.12 is in the contour of the cycle at line 9 (P to Q): it applies to the "
            "G70 finishing pass; left unchanged") in messages  # fmt: skip
    assert any(line == 10 and m.startswith("S200 is in the contour") for line, m in messages)
    assert (18, "F2.0 is the thread lead; left unchanged") in messages
    assert any(
        line == 15 and m.startswith("no F word to rewrite in N200-N240") for line, m in messages
    )
    assert_only_words_changed(text, result)


def test_tapping_pitch_is_left_alone():
    text = program("N1 G21 G95 G97 S300 M03", "N2 G84 Z-10. F1.25", "N3 X0. Z-12.", "N4 G80")
    result = rewrite(text, "rough-od=N1:N4")
    assert [c.old for c in result.changes] == ["S300"]
    assert any("tapping pitch" in w.message for w in result.warnings)


def test_a_range_without_f_or_s_is_reported_not_invented():
    text = program("N1 G21 G95 G96 S150 M03", "N2 G01 X10. F0.2", "N3 G00 X20.", "N4 G01 Z-5.")
    result = rewrite(text, "rough-od=N3:N4")
    assert result.changes == ()
    assert result.text == text
    assert [w.message for w in result.warnings] == [
        "no F word to rewrite in N3-N4 (lines 3-4): F0.2 from line 2 stays in force; add one "
        "to the range to carry the setpoint",
        "no S word to rewrite in N3-N4 (lines 3-4): S150 from line 1 stays in force; add one "
        "to the range to carry the setpoint",
    ]


def test_a_new_feed_still_in_force_after_the_range_is_reported():
    text = program(
        "N1 G21 G95 G96 S150 M03", "N2 G01 X50. F0.2", "N3 Z-10.", "N4 Z-20.", "N5 F0.1", "N6 M30"
    )
    result = rewrite(text, "rough-od=N1:N3")
    assert [(w.line, w.message) for w in result.warnings] == [
        (4, "the new F of N1-N3 is still in force for the cutting move at line 4, after the range"),
        (4, "the new S of N1-N3 is still in force for the cutting move at line 4, after the range"),
    ]


def test_calls_inside_a_range_and_feed_per_minute_under_css_are_reported():
    text = program("N1 G21 G94 G96 S150 M03", "N2 G01 X50. F200", "N3 M98 P100")
    result = rewrite(text, "rough-od=N1:N3")
    messages = [w.message for w in result.warnings]
    assert any("feed per minute (G94) under constant surface speed" in m for m in messages)
    assert any(m.startswith("M98 calls a subprogram") for m in messages)
