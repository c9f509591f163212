"""``rcb gcode`` streamed (issue 29, point 4/5), properties (Hypothesis): the plain-line reader
reads as the character loop, the contour sweep finds what the table found, and lines without a
change come back byte for byte.
"""

from __future__ import annotations

import io

import pytest
from gcode_support import program, stream
from hypothesis import given, settings
from hypothesis import strategies as st

from supervisor.gcode import parse_program
from supervisor.gcode.contours import ContourSweep, Cycles, cycle_of
from supervisor.gcode.lexer import _checked, _scanned_words, read_block
from supervisor.gcode.scan import first_lines

# --------------------------------------------------------------------------------------------
# properties: the plain-line reader, the contours, untouched bytes

_LINE = st.text(alphabet="NGFSXZPQ0123456789.+- \t()/;%:#[]xfgn", max_size=30)


@settings(max_examples=500, deadline=None)
@given(_LINE)
def test_the_plain_line_reader_reads_as_the_character_loop(text):
    block = read_block(text, "\n", 2)
    if not block.marker:
        assert block == _checked(2, text, "\n", *_scanned_words(text, 0))


@pytest.mark.parametrize(
    "text",
    ["N10 G01 X10. (F0.2) F0.3 (S1)", "n1 g01 x 10. f .3 ; S9 (", ":100 (A)(B)  ", "N1 X1(F2"],
)
def test_the_plain_line_reader_on_comments_and_spaces(text):
    assert read_block(text, "", 3) == _checked(3, text, "", *_scanned_words(text, 0))


def _old_contours(blocks) -> dict[int, int]:
    """Contour line → cycle line, every line in a table (the code before the sweep)."""
    line_of: dict[int, int] = {}
    for block in blocks:
        if block.number is not None and not block.problem:
            line_of.setdefault(block.number, block.line)
    inside: dict[int, int] = {}
    for block in blocks:
        cycle = cycle_of(block)
        if cycle is None:
            continue
        first, last = line_of.get(cycle.first), line_of.get(cycle.last)
        if first is not None and last is not None:
            for line in range(first, last + 1):
                inside.setdefault(line, block.line)
    return inside


@st.composite
def cycle_programs(draw):
    lines = []
    for _ in range(draw(st.integers(1, 25))):
        n = draw(st.integers(1, 9))
        if draw(st.booleans()):
            p, q = draw(st.integers(1, 9)), draw(st.integers(1, 9))
            lines.append(f"N{n} G{draw(st.sampled_from([70, 71, 72, 73, 1]))} P{p} Q{q}")
        else:
            lines.append(draw(st.sampled_from([f"N{n} G01 X1.", "G01 Z2.", f"N{n} #1=2"])))
    return program(*lines)


@settings(max_examples=300, deadline=None)
@given(cycle_programs())
def test_the_contour_sweep_finds_what_the_table_found(text):
    blocks = parse_program(text)
    cycles = Cycles()
    for cycle in filter(None, map(cycle_of, blocks)):
        cycles.add(cycle)
    index = first_lines(io.BytesIO(text.encode()), cycles.named(), "IN.nc")
    sweep = ContourSweep.of(cycles, index)
    expected = _old_contours(blocks)
    assert {b.line: sweep.cycle_at(b.line) for b in blocks} == {
        b.line: expected.get(b.line) for b in blocks
    }


def test_a_cycle_naming_a_block_beyond_18_digits_names_none():
    big = 10**19
    block = read_block(f"N5 G71 P{big} Q7", "", 1)
    assert cycle_of(block) == (1, -1, 7)
    index = Cycles().named()
    assert big not in index and 5 not in index


@settings(max_examples=100, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sampled_from(["G01 X10. F0.2", "G00 Z5.", "S150", "(C)", "", "G01 Z-2. F.1"]),
            st.binary(max_size=6).filter(lambda b: b"\n" not in b and b")" not in b),
            st.sampled_from([b"\n", b"\r\n"]),
        ),
        min_size=1,
        max_size=12,
    )
)
def test_lines_without_a_change_come_back_byte_for_byte(body):
    lines = [b"N1 G21 G95 G96 S150 M03\n"]
    for k, (words, junk, end) in enumerate(body):
        lines.append(f"N{k + 2} {words} ".encode() + b"(" + junk + b")" + end)
    lines.append(f"N{len(body) + 2} M30\n".encode())
    written, report = stream(b"".join(lines), f"rough-od=N1:N{len(body) + 1}")
    out = [line + b"\n" for line in written.split(b"\n")[:-1]]
    assert len(out) == len(lines) and b"".join(out) == written
    changed = {c.line for c in report.changes}
    for number, (before, after) in enumerate(zip(lines, out, strict=True), start=1):
        if number not in changed:
            assert after == before
        elif b" (" in before:
            assert after.endswith(before[before.index(b" (") :])  # the comment's bytes
