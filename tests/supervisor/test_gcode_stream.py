"""``rcb gcode`` streamed (issue 29, point 4/5): bounded lines, bounded output, same bytes.

The rewrite reads the program a line at a time and writes the new one as it goes
(:func:`supervisor.gcode.rewrite_stream`). The golden files ``cycles.golden.nc`` and
``mixed.golden.nc`` were written by the in-memory rewrite this replaced (commit 164862a), as
``demo_g95_g96.golden.nc`` and ``g94_g97.golden.nc`` were before it. No test here is timed:
``benchmarks/gcode_memory.py`` prints the time and memory. The properties of the reader and the
sweep are in test_gcode_stream_properties.py, the command in test_gcode_stream_cli.py.
"""

from __future__ import annotations

import io

import pytest
from gcode_support import DATA, SETPOINTS, THREAD, long_program, program, refused, rewrite, stream
from hypothesis import given, settings
from hypothesis import strategies as st

from models.errors import MAX_ECHO
from supervisor.gcode import (
    MAX_LINE_BYTES,
    MAX_LISTED,
    GcodeError,
    parse_range,
    rewrite_program,
    rewrite_stream,
)
from supervisor.gcode.result import Listing

GOLDEN = [
    ("demo_g95_g96", ("rough-od=N100:N180", "finish-od=N300:N350")),
    ("g94_g97", ("rough-od=N10:N60",)),
    ("cycles", ("rough-od=N100:N190", "thread=N200:N240")),
    ("mixed", ("rough-od=N100:N150", "finish-od=N300:N340")),
]


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
