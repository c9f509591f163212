"""``rcb gcode`` streamed (issue 29, point 4/5): bounded lines, bounded output, same bytes.

The rewrite reads the program a line at a time and writes the new one as it goes
(:func:`supervisor.gcode.rewrite_stream`). The golden files ``cycles.golden.nc`` and
``mixed.golden.nc`` were written by the in-memory rewrite this replaced (commit 164862a), as
``demo_g95_g96.golden.nc`` and ``g94_g97.golden.nc`` were before it. No test here is timed:
``benchmarks/gcode_memory.py`` prints the time and memory.
"""

from __future__ import annotations

import io
import json
import re
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_gcode import (
    DATA,
    SETPOINTS,
    cli_args,
    program,
    refused,
    rewrite,
    run,
    stored_plan,  # noqa: F401 (a fixture)
)

from api.cli import gcode as cli
from models.errors import MAX_ECHO
from supervisor.gcode import (
    MAX_LINE_BYTES,
    MAX_LISTED,
    GcodeError,
    OperationSetpoint,
    parse_program,
    parse_range,
    rewrite_program,
    rewrite_stream,
)
from supervisor.gcode.contours import ContourSweep, Cycles, cycle_of
from supervisor.gcode.lexer import _checked, _scanned_words, read_block
from supervisor.gcode.result import Listing
from supervisor.gcode.scan import first_lines

THREAD = OperationSetpoint("thread", feed_mm_rev=0.2, speed_m_min=100, workpiece_diameter_mm=50)
GOLDEN = [
    ("demo_g95_g96", ("rough-od=N100:N180", "finish-od=N300:N350")),
    ("g94_g97", ("rough-od=N10:N60",)),
    ("cycles", ("rough-od=N100:N190", "thread=N200:N240")),
    ("mixed", ("rough-od=N100:N150", "finish-od=N300:N340")),
]
#: One part of a long program: block numbers ``{0}``..``{9}`` (``n``, ``n + 10`` ...).
PART = [
    "(PART)",
    "N{0} T0101",
    "N{1} G96 S187 M03",
    "N{2} G00 X62. Z2.",
    "N{3} G71 P{4} Q{6} U0.4 W0.1 F0.25",
    "N{4} G00 X40. F0.12",
    "N{5} G01 Z-20.",
    "N{6} X62.",
    "N{7} G01 Z-110. F0.25",
    "N{8} G32 Z-30. F2.0",
    "N{9} G01 X64. F.3",
]


def stream(data: bytes, *maps: str, listed: int | None = None, setpoints=None):
    """The new program's bytes and the report of :func:`rewrite_stream` on ``data``."""
    target = io.BytesIO()
    report = rewrite_stream(
        io.BytesIO(data),
        target,
        setpoints or {**SETPOINTS, "thread": THREAD},
        [parse_range(m) for m in maps],
        program_name="IN.nc",
        listed=listed,
    )
    return target.getvalue(), report


def long_program(parts: int, ending: str = "\n") -> str:
    """``parts`` parts after a G21 G95 header, each with new block numbers, then M30."""
    lines = ["%", "O1234", "N1 G21 G95 G50 S3000"]
    for part in range(parts):
        first = 100 + 100 * part
        lines += [line.format(*(first + 10 * k for k in range(10))) for line in PART]
    lines += [f"N{100 + 100 * parts} M30", "%"]
    return ending.join(lines) + ending


# --------------------------------------------------------------------------------------------
# the same bytes as the in-memory rewrite


@pytest.mark.parametrize(("name", "maps"), GOLDEN)
@pytest.mark.parametrize("ending", [b"\n", b"\r\n"])
def test_stream_writes_the_golden_files_byte_for_byte(name, maps, ending):
    source = (DATA / f"{name}.nc").read_bytes().replace(b"\n", ending)
    written, report = stream(source, *maps)
    assert written == (DATA / f"{name}.golden.nc").read_bytes().replace(b"\n", ending)
    assert report.change_count == len(report.changes) > 0
    assert rewrite_program(source.decode(), {**SETPOINTS, "thread": THREAD}, [
        parse_range(m) for m in maps
    ], program_name="IN.nc").text.encode() == written  # fmt: skip


def test_golden_files_of_the_cycles_and_mixed_programs():
    """What the in-memory rewrite wrote, reviewed: the words of test_gcode's assertions."""
    cycles = (DATA / "cycles.golden.nc").read_text().splitlines()
    assert cycles[5] == "N110 G96 S200 M03"
    assert cycles[8] == "N140 G71 P150 Q180 U0.4 W0.1 F0.325"
    assert cycles[9] == "N150 G00 X40. F0.12 S200"  # the contour: left alone
    assert cycles[15] == "N210 G97 S636 M03"
    assert cycles[17] == "N230 G32 Z-30. F2.0"  # the thread lead: left alone
    mixed = (DATA / "mixed.golden.nc").read_text().splitlines()
    assert [mixed[i] for i in (5, 7, 11, 12, 13)] == [
        "N110 G96 S200 M03",
        "N130 G01 Z-110. F0.325 ; ROUGH F0.3",
        "N310 G97 S1209 M03",
        "N320 G94 G01 X52. F145.1",
        "N330 Z-110. F145.1",
    ]


def test_bytes_that_are_not_utf8_and_a_bom_come_back_unchanged():
    source = b"\xef\xbb\xbfN1 G21 G95 G96 (\xe9\xff)\r\nN2 S150 M03 ; \x80\nN3 G01 X10. F0.2"
    written, _ = stream(source, "rough-od=N1:N3")
    assert (
        written
        == b"\xef\xbb\xbfN1 G21 G95 G96 (\xe9\xff)\r\nN2 S200 M03 ; \x80\nN3 G01 X10. F0.325"
    )


# --------------------------------------------------------------------------------------------
# a long program: every line read, counted in full, listed up to the cap


def test_a_program_of_a_few_megabytes_is_rewritten_whole(tmp_path):
    parts = 10_000  # 2.2 MB, 110 000 lines, read and written through files
    text = long_program(parts, ending="\r\n")
    source, target = tmp_path / "IN.nc", tmp_path / "OUT.nc"
    source.write_bytes(text.encode())
    with source.open("rb") as file, target.open("wb") as out:
        maps = [parse_range(f"rough-od=N100:N{100 * parts + 90}")]
        report = rewrite_stream(file, out, SETPOINTS, maps, listed=None)
    assert len(text) > 2e6
    # per part: S187, the G71 block's F0.25, F0.25, F.3; the contour's F0.12 and the thread lead
    # are left alone, with a warning each
    assert report.change_count == len(report.changes) == 4 * parts
    assert report.warning_count == 2 * parts
    assert report.changes_by_operation == {"rough-od": 4 * parts}
    new = target.read_bytes().decode().split("\r\n")
    old = text.split("\r\n")
    assert len(new) == len(old)
    edited = {c.line: c for c in report.changes}
    for number, (before, after) in enumerate(zip(old, new, strict=True), start=1):
        if number in edited:
            c = edited[number]
            before = before[: c.column - 1] + c.new + before[c.column - 1 + len(c.old) :]
        assert after == before
    last = 3 + 11 * (parts - 1)  # the last part's first line (0-based)
    assert new[last + 2] == f"N{100 * parts + 10} G96 S200 M03"
    assert new[last + 5] == f"N{100 * parts + 40} G00 X40. F0.12"
    assert new[last + 10] == f"N{100 * parts + 90} G01 X64. F.325"
    assert new[-3:] == [f"N{100 + 100 * parts} M30", "%", ""]


def test_changes_and_warnings_are_counted_in_full_and_listed_up_to_the_cap():
    parts = 400
    _, report = stream(long_program(parts).encode(), "rough-od=N100:N40090", listed=MAX_LISTED)
    assert (report.change_count, len(report.changes)) == (4 * parts, MAX_LISTED)
    assert (report.warning_count, len(report.warnings)) == (2 * parts, 2 * parts)
    assert [c.line for c in report.changes] == sorted(c.line for c in report.changes)
    assert report.changes[-1].line == 3 + 11 * 249 + 11  # the 1000th: part 250's last F
    _, few = stream(long_program(parts).encode(), "rough-od=N100:N40090", listed=3)
    assert [w.line for w in few.warnings] == [9, 13, 20]  # contour F (line 9), lead (13) ...
    assert few.warning_count == 2 * parts


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 50), st.integers()), max_size=40), st.integers(0, 8))
def test_a_listing_keeps_the_first_by_key_in_the_order_added(items, cap):
    listing: Listing[int] = Listing(cap)
    for key, item in items:
        listing.add(key, item)
    assert listing.count == len(items)
    expected = [item for _, item in sorted(items, key=lambda pair: pair[0])][:cap]
    assert list(listing.listed()) == expected


# --------------------------------------------------------------------------------------------
# bounded lines


class CountingSource(io.BytesIO):
    """A program in memory that counts the bytes read from it."""

    def __init__(self, data: bytes) -> None:
        super().__init__(data)
        self.read_bytes = 0

    def readline(self, size: int | None = -1, /) -> bytes:  # type: ignore[override]
        line = super().readline(size)
        self.read_bytes += len(line)
        return line


def test_a_line_longer_than_the_limit_is_refused_without_reading_it_all():
    header = b"N1 G21 G95 G96\n"
    source = CountingSource(header + b"N2" + b" F0.1" * 2_000_000 + b"\nN3 M30\n")  # 10 MB
    with pytest.raises(GcodeError) as caught:
        rewrite_stream(source, io.BytesIO(), SETPOINTS, [parse_range("rough-od=N1:N3")])
    err = caught.value
    assert err.field == "program line 2"
    assert err.value == ("N2" + " F0.1" * 40)[:MAX_ECHO]  # its first 200 characters
    assert f"is longer than {MAX_LINE_BYTES} bytes" in err.reason
    assert len(str(err)) < 400 and "\n" not in str(err)
    assert source.read_bytes == len(header) + MAX_LINE_BYTES + 2


@pytest.mark.parametrize("ending", ["\n", "\r\n", ""])
def test_a_line_of_exactly_the_limit_is_read_and_one_more_byte_is_refused(ending):
    def source(length: int) -> str:
        line = "N2 G01 X10. F0.2 (" + "C" * (length - 19) + ")"
        assert len(line) == length
        return program("N1 G21 G95 G96 S150", ending="\n") + line + ending

    result = rewrite(source(MAX_LINE_BYTES), "rough-od=N1:N2")
    assert [c.new for c in result.changes] == ["S200", "F0.325"]
    assert result.text.endswith("F0.325 (" + "C" * (MAX_LINE_BYTES - 19) + ")" + ending)
    err = refused(source(MAX_LINE_BYTES + 1), "rough-od=N1:N2")
    assert err.field == "IN.nc line 2" and "longer than 4096 bytes" in err.reason


def test_a_long_line_after_the_ranges_is_refused_too():
    text = program("N1 G21 G95 G96 S150", "N2 G01 X10. F0.2", "(" + "C" * 5000 + ")")
    err = refused(text, "rough-od=N1:N2")
    assert err.field == "IN.nc line 3" and err.value.startswith("(CCC")


def test_a_block_number_on_many_lines_lists_ten():
    text = program("N1 G21 G95 G96", *["N2 G01 X10. F0.2"] * 25)
    err = refused(text, "rough-od=N1:N2")
    assert err.reason == (
        "block N2 is on several lines (2, 3, 4, 5, 6, 7, 8, 9, 10, 11 and 15 more)"
    )


def test_messages_cut_a_word_of_thousands_of_digits():
    clamp = "S" + "0" * 3000 + "900"
    err = refused(program(f"N1 G21 G95 G96 G50 {clamp}", "N2 S150 M03"), "rough-od=N1:N2")
    assert "the spindle clamp S0000000" in err.reason and "…" in err.reason
    assert len(str(err)) < 600
    feed = "F" + "0" * 3000 + ".2"
    result = rewrite(program("N1 G21 G95 G96 S150", f"N2 G32 Z-5. {feed}"), "rough-od=N1:N2")
    assert len(result.warnings[0].message) < 100  # the thread lead, cut
    huge = rewrite(program("N1 G21 G95 G96 S150", f"N2 G01 Z-5. {feed}"), "rough-od=N1:N2")
    assert huge.changes[-1].old == feed  # a change says exactly what it replaced


class ChangingSource(io.BytesIO):
    """A program that gains a line once it was read the first time."""

    def __init__(self, data: bytes) -> None:
        super().__init__(data)
        self.seeks = 0

    def seek(self, offset: int, whence: int = 0, /) -> int:
        self.seeks += 1
        if self.seeks == 2:  # the second reading starts
            super().seek(0, io.SEEK_END)
            self.write(b"N9 M30\n")
        return super().seek(offset, whence)


def test_a_program_changed_between_two_readings_is_refused():
    source = ChangingSource(program("N1 G21 G95 G96 S150", "N2 G01 X10. F0.2").encode())
    with pytest.raises(GcodeError, match="changed while it was read"):
        rewrite_stream(source, io.BytesIO(), SETPOINTS, [parse_range("rough-od=N1:N2")])


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


# --------------------------------------------------------------------------------------------
# the command: bounded output, nothing written on an error


def _long_cli_args(url: str, plan_id: int, tmp_path: Path, parts: int) -> tuple[list[str], Path]:
    source = tmp_path / "LONG.nc"
    source.write_text(long_program(parts))
    out = tmp_path / "OUT.nc"
    args = [str(plan_id), "--program", str(source), "--out", str(out)]
    return [*args, "--map", f"rough-od=N100:N{100 + 100 * parts - 10}", "--db", url], out


def test_cli_json_lists_the_first_changes_and_counts_them_all(stored_plan, tmp_path):  # noqa: F811
    url, plan_id, _ = stored_plan
    args, out = _long_cli_args(url, plan_id, tmp_path, 400)
    result = run([*args, "--json"])
    assert result.exit_code == 0, result.stderr
    data = json.loads(result.stdout)
    assert (data["changes_total"], len(data["changes"])) == (1600, MAX_LISTED)
    assert data["changes_truncated"] == 1600 - MAX_LISTED
    assert (data["warnings_total"], data["warnings_truncated"], len(data["warnings"])) == (
        800,
        0,
        800,
    )
    assert data["operations"][0]["words_changed"] == 1600
    warned = [line for line in result.stderr.splitlines() if line.startswith("rcb: warning:")]
    assert len(warned) == cli.SHOWN + 1
    assert warned[-1] == f"rcb: warning: LONG.nc: {800 - cli.SHOWN} more warnings " + (
        "(--json lists the first 1000)"
    )
    assert result.stderr.endswith("(1600 words changed)\n")
    assert out.read_text().count("F0.") > 1000


def test_cli_table_shows_the_first_fifty(stored_plan, tmp_path):  # noqa: F811
    url, plan_id, _ = stored_plan
    args, _ = _long_cli_args(url, plan_id, tmp_path, 100)
    result = run(args)
    assert result.exit_code == 0, result.stderr
    assert "400 words changed" in result.stdout
    assert result.stdout.endswith("... and 350 more words changed (--json lists the first 1000)\n")
    assert result.stdout.count("more words changed") == 1
    rows = [line for line in result.stdout.splitlines() if re.match(r"\s*\d+\s+rough-od", line)]
    assert len(rows) == cli.SHOWN


def test_cli_refuses_a_long_line_in_one_bounded_line_and_writes_nothing(stored_plan, tmp_path):  # noqa: F811
    url, plan_id, _ = stored_plan
    source = tmp_path / "BIG.nc"
    source.write_bytes(b"N100 G21 G95 G96\nN110" + b" F0.1" * 200_000 + b"\nN180 M30\n")
    out = tmp_path / "OUT.nc"
    args = [str(plan_id), "--program", str(source), "--out", str(out)]
    result = run([*args, "--map", "rough-od=N100:N180", "--db", url])
    assert result.exit_code == 2
    assert result.stderr.startswith("rcb: error: BIG.nc line 2 = 'N110 F0.1 F0.1")
    assert "is longer than 4096 bytes" in result.stderr
    assert result.stderr.count("\n") == 1 and len(result.stderr) < 500
    assert sorted(p.name for p in tmp_path.iterdir()) == ["BIG.nc"]


def test_cli_writes_nothing_when_the_end_of_a_long_program_is_refused(stored_plan, tmp_path):  # noqa: F811
    url, plan_id, _ = stored_plan
    args, out = _long_cli_args(url, plan_id, tmp_path, 2000)
    source = tmp_path / "LONG.nc"
    text = source.read_text().replace("N200090 G01 X64. F.3", "N200090 G98 G01 X64. F.3")
    source.write_text(text)  # the last part's last F: refused once 2 MB are written
    result = run(args)
    assert result.exit_code == 2, result.stderr
    assert result.stderr.startswith("rcb: error: LONG.nc line 22003 = 'F.3': the feed mode is")
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["LONG.nc"]


def test_cli_refuses_a_program_of_only_whitespace(stored_plan, tmp_path):  # noqa: F811
    url, plan_id, _ = stored_plan
    source = tmp_path / "BLANK.nc"
    source.write_bytes(b" \r\n\t" * 40_000)  # more than one chunk
    args = [str(plan_id), "--program", str(source), "--out", str(tmp_path / "OUT.nc")]
    result = run([*args, "--map", "rough-od=N100:N180", "--db", url])
    assert result.exit_code == 2 and "is empty" in result.stderr


def test_the_help_states_the_caps_as_they_are():
    from api.cli.gcode import gcode

    help_text = " ".join((gcode.__doc__ or "").split())
    assert f"first {cli.SHOWN} changes" in help_text and f"first {cli.SHOWN} warnings" in help_text
    assert f"--json the first {MAX_LISTED} of each" in help_text
    assert f"over {MAX_LINE_BYTES} bytes" in help_text
    assert cli._JSON_LISTS == f"--json lists the first {MAX_LISTED}"


def test_the_cli_reads_what_the_stream_writes(stored_plan, tmp_path):  # noqa: F811
    url, plan_id, _ = stored_plan
    out = tmp_path / "OUT.nc"
    assert run(cli_args(url, plan_id, out)).exit_code == 0
    assert out.read_bytes().count(b"\n") == (DATA / "demo_g95_g96.nc").read_bytes().count(b"\n")
