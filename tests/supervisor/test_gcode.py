"""``rcb gcode``: F and S words of a lathe program rewritten with the setpoints, nothing else.

Programs are synthetic (``tests/data/gcode/*.nc`` and inline): the words rewritten, the numbers
written, random programs (Hypothesis) and the golden files. Refusals and warnings:
test_gcode_refusals.py; the command: test_gcode_cli.py; the streaming rewrite:
test_gcode_stream.py.
"""

from __future__ import annotations

import math
from decimal import Decimal

import pytest
from gcode_support import DATA, assert_only_words_changed, program, rewrite, words
from hypothesis import given, settings
from hypothesis import strategies as st

from supervisor.gcode import OperationSetpoint, parse_program
from supervisor.gcode.numbers import _floor, _styled

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
        (21, "F.1", "F.12", "G95"),  # line 19's S190 is finish-od's 190 m/min already: no change
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
    assert not result.changes  # a word the setpoint leaves as it is is no change


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
