"""``rcb gcode``: F and S words of a lathe program rewritten with the setpoints, nothing else.

Programs are synthetic (``tests/data/gcode/*.nc`` and inline); the CLI tests store the
demonstration plan in a temporary SQLite database and check the written F and S against the
setpoints in force.
"""

from __future__ import annotations

import json
import math
import tomllib
from collections import defaultdict
from decimal import Decimal
from pathlib import Path

import pytest
import typer
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from api.services import read as queries
from api.services.plans import create_plan
from db.engine import make_engine, upgrade
from supervisor.gcode import (
    BlockRange,
    GcodeError,
    OperationSetpoint,
    RewriteResult,
    parse_program,
    parse_range,
    rewrite_program,
)
from supervisor.gcode.numbers import _floor, _styled

from conftest import DEMO_PLAN, ROOT

DATA = ROOT / "tests" / "data" / "gcode"

#: Round numbers: n = 1000·200/(π·60) = 1061.03 rpm, f·n = 344.84 mm/min.
ROUGH = OperationSetpoint(
    "rough-od", feed_mm_rev=0.325, speed_m_min=200.0, workpiece_diameter_mm=60
)
#: n = 1000·190/(π·50) = 1209.58 rpm, f·n = 145.15 mm/min.
FINISH = OperationSetpoint(
    "finish-od", feed_mm_rev=0.12, speed_m_min=190.0, workpiece_diameter_mm=50
)
SETPOINTS = {"rough-od": ROUGH, "finish-od": FINISH}


def program(*lines: str, ending: str = "\n") -> str:
    return ending.join(lines) + ending


def rewrite(text: str, *maps: str, setpoints=None) -> RewriteResult:
    return rewrite_program(
        text, setpoints or SETPOINTS, [parse_range(m) for m in maps], program_name="IN.nc"
    )


def assert_only_words_changed(before: str, result: RewriteResult) -> None:
    """Every byte outside the changed F/S words is the same, line by line, endings included."""
    old_lines, new_lines = before.split("\n"), result.text.split("\n")
    assert len(old_lines) == len(new_lines)
    by_line = defaultdict(list)
    for change in result.changes:
        assert change.old[0] in "FfSs" and change.new[0] == change.old[0]
        by_line[change.line].append(change)
    for number, (old, new) in enumerate(zip(old_lines, new_lines, strict=True), start=1):
        expected = old
        for change in sorted(by_line[number], key=lambda c: -c.column):
            start = change.column - 1
            assert expected[start : start + len(change.old)] == change.old
            expected = expected[:start] + change.new + expected[start + len(change.old) :]
        assert new == expected, f"line {number}"


def words(text: str, line: int) -> dict[str, str]:
    """The words of one line: letter → number text (the last one of each letter)."""
    block = parse_program(text)[line - 1]
    return {w.letter: w.number for w in block.words}


# --------------------------------------------------------------------------------------------
# rewriting


def test_g95_g96_with_g50_clamp_rewrites_only_the_f_and_s_words():
    text = (DATA / "demo_g95_g96.nc").read_text()
    result = rewrite(text, "rough-od=N100:N180", "finish-od=N300:N350")
    assert [(c.line, c.old, c.new, c.mode) for c in result.changes] == [
        (9, "S187", "S200", "G96"),
        (11, "F0.25", "F0.325", "G95"),
        (12, "F0.3", "F0.325", "G95"),
        (15, "F0.25", "F0.325", "G95"),
        (19, "S190", "S190", "G96"),
        (21, "F.1", "F.12", "G95"),
    ]
    assert_only_words_changed(text, result)
    out = result.text.splitlines()
    assert out[2] == "(FEED F0.3 S200 IN THIS COMMENT MUST NOT CHANGE)"
    assert out[3] == "N10 G21 G40 G18 G95 ; METRIC, FEED PER REV F0.25"
    assert out[4] == "N20 G50 S3000 (CLAMP S3000)"  # the clamp is not a speed
    assert out[8] == "N110 G96 S200 M03 (VC S187)"
    assert out[11] == "N140 X64. F0.325 (RETRACT F0.3)"
    assert out[20] == "N330 G01   Z-110.  F.12   (FINISH PASS)"
    assert result.warnings == ()
    assert [(r.first_line, r.last_line) for r in result.ranges] == [(8, 16), (18, 23)]


def test_g94_g97_writes_rpm_and_feed_per_minute_at_the_operation_diameter():
    text = (DATA / "g94_g97.nc").read_text()
    result = rewrite(text, "rough-od=N10:N60")
    rpm = 1000 * 200 / (math.pi * 60)  # Sandvik Coromant: n = 1000 vc / (π Dm)
    assert [(c.old, c.new, c.quantity) for c in result.changes] == [
        ("S1000", f"S{math.floor(rpm)}", "spindle_rpm"),  # S1061
        ("F250", f"F{math.floor(0.325 * rpm * 10) / 10}", "feed_rate_mm_min"),  # F344.8
    ]
    assert_only_words_changed(text, result)


def test_mixed_modes_in_one_program():
    text = (DATA / "mixed.nc").read_text()
    result = rewrite(text, "rough-od=N100:N150", "finish-od=N300:N340")
    assert [(c.line, c.old, c.new, c.mode) for c in result.changes] == [
        (6, "S187", "S200", "G96"),
        (8, "F0.25", "F0.325", "G95"),
        (12, "S1500", "S1209", "G97"),  # 1209.58 rpm, rounded down
        (13, "F120.", "F145.1", "G94"),  # 0.12 x 1209.58 = 145.15 mm/min
        (14, "F120.0", "F145.1", "G94"),
    ]
    assert_only_words_changed(text, result)
    assert result.text.splitlines()[7] == "N130 G01 Z-110. F0.325 ; ROUGH F0.3"


def test_crlf_line_endings_are_kept():
    lf = (DATA / "demo_g95_g96.nc").read_text()
    crlf = lf.replace("\n", "\r\n")
    result = rewrite(crlf, "rough-od=N100:N180", "finish-od=N300:N350")
    assert result.text == rewrite(lf, "rough-od=N100:N180", "finish-od=N300:N350").text.replace(
        "\n", "\r\n"
    )
    assert result.text.count("\r\n") == crlf.count("\r\n") == crlf.count("\n")
    assert_only_words_changed(crlf, result)


def test_mixed_endings_a_last_line_without_one_and_a_bom_are_kept():
    text = "\ufeff" + program("N1 G21 G95 G96", "N2 S150 M03\r", "N3 G01 X10. F0.2")[:-1]
    result = rewrite(text, "rough-od=N1:N3")
    assert result.text == "\ufeffN1 G21 G95 G96\nN2 S200 M03\r\nN3 G01 X10. F0.325"


def test_comments_with_f_and_s_letters_are_never_touched():
    text = program(
        "N1 G21 G95 G96 (F0.1 S100)",
        "N2 S150 M03 (S150 F0.2) ; S99 F9",
        "N3 G01 X10.(F0.2)F0.2(S1)",
        "(F0.2 S150)",
        "; F0.2 S150",
    )
    result = rewrite(text, "rough-od=N1:N3")
    assert result.text == program(
        "N1 G21 G95 G96 (F0.1 S100)",
        "N2 S200 M03 (S150 F0.2) ; S99 F9",
        "N3 G01 X10.(F0.2)F0.325(S1)",
        "(F0.2 S150)",
        "; F0.2 S150",
    )
    assert_only_words_changed(text, result)


def test_lower_case_letters_and_spaces_inside_a_word_are_kept():
    text = program("n1 g21 g95 g96", "n2 s 150 m03", "n3 g01 x10. f 0.20")
    assert rewrite(text, "rough-od=N1:N3").text == program(
        "n1 g21 g95 g96", "n2 s 200 m03", "n3 g01 x10. f 0.325"
    )


def test_modes_set_in_the_block_apply_to_its_own_words():
    text = program("N1 G21", "N2 G95 G96 S150 M03", "N3 G01 G94 X10. F300")
    result = rewrite(text, "rough-od=N2:N3")
    assert [(c.new, c.mode) for c in result.changes] == [("S200", "G96"), ("F344.8", "G94")]


def test_optional_skip_and_block_number_zero_padding():
    text = program("N0010 G21 G95 G96", "/N0020 S150 M03", "N0030 G01 X10. F0.2")
    result = rewrite(text, "rough-od=N10:N30")
    assert result.text == program("N0010 G21 G95 G96", "/N0020 S200 M03", "N0030 G01 X10. F0.325")


def test_unnumbered_lines_inside_a_range_are_rewritten_and_after_it_are_not():
    text = program("N1 G21 G95 G96 S150 M03", "G01 X10. F0.2", "N2 Z-5.", "G01 X20. F0.2", "N3 M30")
    result = rewrite(text, "rough-od=N1:N2")
    assert [c.line for c in result.changes] == [1, 2]
    assert result.text.splitlines()[3] == "G01 X20. F0.2"


# --------------------------------------------------------------------------------------------
# numbers


@pytest.mark.parametrize(
    ("original", "value", "places", "point", "expected"),
    [
        ("0.25", 0.325, 4, True, "0.325"),  # the brief's example
        (".25", 0.325, 4, True, ".325"),  # no leading zero
        ("0.250", 0.3, 4, True, "0.300"),  # as many decimals as the original
        ("0.2500", 0.32481066554710364, 4, True, "0.3248"),  # 4 decimals, rounded down
        ("1", 1.0, 4, True, "1."),  # mm/rev always has a decimal point
        ("200", 230.0, 0, False, "230"),  # the brief's example
        ("200.", 230.0, 0, False, "230."),  # trailing point kept
        ("200.0", 230.0, 0, False, "230.0"),
        ("200", 199.99999999999991, 0, False, "200"),  # an optimum on a bound: float noise
        ("200", 187.9, 0, False, "187"),  # never faster than the setpoint
        ("250", 344.8357, 1, False, "344.8"),
        ("250.", 344.0, 1, False, "344."),
        ("+0.25", 0.3, 4, True, "+0.30"),
    ],
)
def test_number_style(original, value, places, point, expected):
    assert _styled(_floor(value, places), original, places, point=point) == expected


def test_values_are_rounded_down_never_above_the_setpoint():
    op = OperationSetpoint("op", feed_mm_rev=0.12349, speed_m_min=150.99, workpiece_diameter_mm=40)
    text = program("N1 G21 G95 G96 S100 M03", "N2 G01 X10. F0.1")
    result = rewrite(text, "op=N1:N2", setpoints={"op": op})
    assert [c.new for c in result.changes] == ["S150", "F0.1234"]


# --------------------------------------------------------------------------------------------
# refusals


def refused(text: str, *maps: str, setpoints=None) -> GcodeError:
    with pytest.raises(GcodeError) as caught:
        rewrite(text, *maps, setpoints=setpoints)
    return caught.value


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


# --------------------------------------------------------------------------------------------
# properties


@given(st.text())
def test_parse_program_keeps_every_character(text):
    blocks = parse_program(text)
    assert "".join(b.text + b.ending for b in blocks) == text


_COMMENT = st.text(alphabet="FS0123456789.XZ -", max_size=10).map(lambda t: f"({t})")
_SPACE = st.sampled_from(["", " ", "  ", "\t"])


@st.composite
def lathe_programs(draw):
    """A G21/G95/G96 program with one range, varied spacing, comments and number styles."""
    ending = draw(st.sampled_from(["\n", "\r\n"]))
    feed = draw(st.sampled_from(["0.25", ".25", "0.250", "0.2500"]))
    speed = draw(st.sampled_from(["200", "200.", "200.0"]))
    lines = ["%", "O0100" + draw(st.sampled_from(["", " (PART F0.1 S50)"]))]
    lines += ["N10 G21 G95 G50 S3000", f"N20 G96 S{speed} M03{draw(_SPACE)}{draw(_COMMENT)}"]
    number = 20
    for _ in range(draw(st.integers(1, 8))):
        kind = draw(st.sampled_from(["cut", "rapid", "comment", "blank", "semicolon"]))
        x = draw(st.integers(10, 60))
        if kind == "cut":
            number += 10
            s = draw(_SPACE)
            lines.append(f"N{number}{s} G01{s} X{x}.{draw(_SPACE)}F{feed}{draw(_SPACE)}")
        elif kind == "rapid":
            number += 10
            lines.append(f"N{number} G00 X{x}. Z2.{draw(_SPACE)}{draw(_COMMENT)}")
        elif kind == "comment":
            lines.append(draw(_COMMENT))
        elif kind == "blank":
            lines.append("")
        else:
            lines.append(f"; F{feed} S{speed}")
    lines += [f"N{number + 10} M30", "%"]
    return ending.join(lines) + ending, f"op=N20:N{number}"


@settings(max_examples=60, deadline=None)
@given(lathe_programs())
def test_programs_already_at_the_setpoint_come_back_byte_for_byte(case):
    text, mapped = case
    op = OperationSetpoint("op", feed_mm_rev=0.25, speed_m_min=200.0, workpiece_diameter_mm=60)
    result = rewrite(text, mapped, setpoints={"op": op})
    assert result.text == text
    assert result.changes  # the S of N20 at least


@settings(max_examples=60, deadline=None)
@given(
    lathe_programs(),
    st.floats(0.05, 0.6),
    st.floats(60.0, 300.0),
)
def test_only_f_and_s_words_change_and_carry_the_setpoint(case, feed, speed):
    text, mapped = case
    op = OperationSetpoint("op", feed_mm_rev=feed, speed_m_min=speed, workpiece_diameter_mm=60)
    result = rewrite(text, mapped, setpoints={"op": op})
    assert_only_words_changed(text, result)
    for change in result.changes:
        value = Decimal(words(result.text, change.line)[change.old[0].upper()])
        if change.quantity == "feed_mm_rev":
            assert feed - 1e-4 - 1e-12 <= value <= feed + 1e-12
        else:
            assert speed - 1 - 1e-9 <= value <= speed + 1e-9


# --------------------------------------------------------------------------------------------
# the command


def _app() -> typer.Typer:
    """``rcb`` itself."""
    from api.cli.main import app as rcb

    return rcb


@pytest.fixture(scope="module")
def stored_plan(tmp_path_factory) -> tuple[str, int, dict]:
    """The demonstration plan in a new SQLite database: URL, plan id, setpoints in force."""
    url = f"sqlite:///{tmp_path_factory.mktemp('gcode') / 'rcb.db'}"
    upgrade(url)
    engine = make_engine(url)
    body = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
    plan_id = create_plan(engine=engine, body=body).body["id"]
    current = queries.current_setpoints(engine=engine, plan_id=plan_id)
    engine.dispose()
    return url, plan_id, {op["name"]: op["setpoint"] for op in current["operations"]}


def run(args: list[str]):
    return CliRunner().invoke(_app(), ["gcode", *args])


def cli_args(url: str, plan_id: int, out: Path, *extra: str) -> list[str]:
    return [
        str(plan_id),
        "--program",
        str(DATA / "demo_g95_g96.nc"),
        "--out",
        str(out),
        "--map",
        "rough-od=N100:N180",
        "--map",
        "finish-od=N300:N350",
        "--db",
        url,
        *extra,
    ]


def test_cli_writes_the_setpoints_in_force(stored_plan, tmp_path):
    url, plan_id, setpoints = stored_plan
    out = tmp_path / "OUT.nc"
    result = run(cli_args(url, plan_id, out))
    assert result.exit_code == 0, result.stderr
    assert "rcb: wrote" in result.stderr and "6 words changed" in result.stderr
    assert "F0.25" in result.stdout and "rough-od" in result.stdout
    text = out.read_text()
    rough, finish = setpoints["rough-od"], setpoints["finish-od"]
    for line, setpoint in ((9, rough), (19, finish)):  # G96: S in m/min
        assert float(words(text, line)["S"]) == pytest.approx(setpoint["speed_m_min"], abs=1)
    for line, setpoint in ((11, rough), (12, rough), (15, rough), (21, finish)):  # G95
        assert float(words(text, line)["F"]) == pytest.approx(setpoint["feed_mm_rev"], abs=1e-4)
    assert words(text, 11)["F"] == f"{math.floor(rough['feed_mm_rev'] * 1e4) / 1e4}"
    assert words(text, 9)["S"] == "200"  # 199.99999999999991: the speed bound
    source = (DATA / "demo_g95_g96.nc").read_bytes()
    assert len(out.read_bytes().splitlines()) == len(source.splitlines())


def test_cli_json(stored_plan, tmp_path):
    url, plan_id, setpoints = stored_plan
    out = tmp_path / "OUT.nc"
    result = run(cli_args(url, plan_id, out, "--json"))
    assert result.exit_code == 0, result.stderr
    data = json.loads(result.stdout)
    assert data["plan_id"] == plan_id and data["setpoint_version"] == 1
    assert [op["name"] for op in data["operations"]] == ["rough-od", "finish-od"]
    assert data["operations"][0]["lines"] == [8, 16]
    assert data["operations"][0]["workpiece_diameter_mm"] == 60
    assert data["operations"][0]["feed_mm_rev"] == setpoints["rough-od"]["feed_mm_rev"]
    assert [c["line"] for c in data["changes"]] == [9, 11, 12, 15, 19, 21]
    assert {"line", "column", "operation", "old", "new", "quantity", "mode"} == set(
        data["changes"][0]
    )
    assert data["warnings"] == []


def test_cli_g94_g97_program(stored_plan, tmp_path):
    url, plan_id, setpoints = stored_plan
    out = tmp_path / "OUT.nc"
    args = [str(plan_id), "--program", str(DATA / "g94_g97.nc"), "--out", str(out)]
    result = run([*args, "--map", "rough-od=N10:N60", "--db", url, "--json"])
    assert result.exit_code == 0, result.stderr
    sp = setpoints["rough-od"]
    rpm = 1000 * sp["speed_m_min"] / (math.pi * 60)
    assert float(words(out.read_text(), 5)["S"]) == pytest.approx(rpm, abs=1)
    assert float(words(out.read_text(), 7)["F"]) == pytest.approx(sp["feed_mm_rev"] * rpm, abs=0.1)


def _bad_program(tmp_path: Path) -> Path:
    path = tmp_path / "BAD.nc"
    path.write_text(program("N100 G21 G96 S150 M03", "N180 G01 X10. F0.2"))
    return path


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"plan": "999"}, "rcb: error: PLAN = 999: no such plan"),
        ({"map": "nope=N100:N180"}, "rcb: error: --map = 'nope=N100:N180': no operation 'nope'"),
        ({"map": "rough-od=N100"}, "rcb: error: --map = 'rough-od=N100': must be OPERATION="),
        ({"map": "rough-od=N100:N999"}, "rcb: error: --map = 'rough-od=N100:N999': no block N999"),
        ({"program": "missing.nc"}, "rcb: error: --program = '"),
        ({"program": "BAD"}, "rcb: error: BAD.nc line 2 = 'F0.2': the feed mode is not known"),
        ({"db": "nowhere"}, "rcb: error: --db = 'sqlite:///"),
    ],
)
def test_cli_errors_are_one_line_exit_2_and_write_nothing(stored_plan, tmp_path, change, message):
    url, plan_id, _ = stored_plan
    out = tmp_path / "OUT.nc"
    program_path = DATA / "demo_g95_g96.nc"
    if change.get("program") == "BAD":
        program_path = _bad_program(tmp_path)
    elif "program" in change:
        program_path = tmp_path / change["program"]
    db = f"sqlite:///{tmp_path / 'none.db'}" if "db" in change else url
    args = [change.get("plan", str(plan_id)), "--program", str(program_path), "--out", str(out)]
    args += ["--map", change.get("map", "rough-od=N100:N180"), "--db", db]
    result = run(args)
    assert result.exit_code == 2
    assert result.stderr.startswith(message), result.stderr
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert not out.exists()
    assert not (tmp_path / "none.db").exists()


def test_cli_refuses_to_overwrite_the_input(stored_plan, tmp_path):
    url, plan_id, _ = stored_plan
    source = tmp_path / "IN.nc"
    source.write_bytes((DATA / "demo_g95_g96.nc").read_bytes())
    args = [str(plan_id), "--program", str(source), "--out", str(source)]
    result = run([*args, "--map", "rough-od=N100:N180", "--db", url])
    assert result.exit_code == 2
    assert "--out" in result.stderr and "is the input program" in result.stderr
    assert source.read_bytes() == (DATA / "demo_g95_g96.nc").read_bytes()


def test_cli_keeps_bytes_that_are_not_utf8(stored_plan, tmp_path):
    url, plan_id, _ = stored_plan
    source = tmp_path / "IN.nc"
    data = (DATA / "g94_g97.nc").read_bytes().replace(b"(G94 / G97", b"(\xe9\xff G94 / G97")
    source.write_bytes(data.replace(b"\n", b"\r\n"))
    out = tmp_path / "OUT.nc"
    args = [str(plan_id), "--program", str(source), "--out", str(out)]
    result = run([*args, "--map", "rough-od=N10:N60", "--db", url])
    assert result.exit_code == 0, result.stderr
    written = out.read_bytes()
    assert b"(\xe9\xff G94 / G97" in written and written.count(b"\r\n") == data.count(b"\n")


@pytest.mark.parametrize(
    ("name", "maps"),
    [
        ("demo_g95_g96", ("rough-od=N100:N180", "finish-od=N300:N350")),
        ("g94_g97", ("rough-od=N10:N60",)),
    ],
)
def test_golden_files(name, maps):
    """The rewrite of each sample program, as reviewed and kept in ``<name>.golden.nc``.

    Setpoints: rough-od f 0.325 mm/rev, v 200 m/min on Ø60 (n 1061.03 rpm, f·n 344.84 mm/min);
    finish-od f 0.12 mm/rev, v 190 m/min on Ø50.
    """
    result = rewrite((DATA / f"{name}.nc").read_text(), *maps)
    assert result.text == (DATA / f"{name}.golden.nc").read_text()
