"""The rewrite of a whole program, streamed: read a line, write a line, in bounded memory.

:func:`rewrite_stream` reads the program from a binary stream and writes the new one to
another, a line at a time: the memory it takes does not grow with the program (but for the
G70-G73 cycles, a few numbers each), and its time grows linearly. It reads the program up to
three times: once to locate the ranges and the first unreadable line and to collect the
cycles (:func:`supervisor.gcode.scan.scan_program`), once more if there are cycles, for the
lines of their contours (:func:`supervisor.gcode.scan.first_lines`), and once to write.
:func:`rewrite_program` does the same on a text in memory.
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol

from supervisor.gcode.contours import ContourSweep
from supervisor.gcode.errors import GcodeError
from supervisor.gcode.lexer import Block, read_block
from supervisor.gcode.modes import _enter, _leave, _unknown
from supervisor.gcode.ranges import BlockRange, OperationSetpoint, ResolvedRange, locate_ranges
from supervisor.gcode.result import MAX_LISTED, Listing, RewriteReport, RewriteResult
from supervisor.gcode.rewrite import Pass, Progress, carry_over, close_range, rewrite_block
from supervisor.gcode.scan import first_lines, scan_program
from supervisor.gcode.source import BYTES, ENCODING, Line, ProgramSource, read_lines


class ProgramTarget(Protocol):
    """Where the new program goes: bytes written in order."""

    def write(self, data: bytes, /) -> int:
        """Write ``data``."""
        ...


def rewrite_stream(
    source: ProgramSource,
    target: ProgramTarget,
    setpoints: Mapping[str, OperationSetpoint],
    ranges: Sequence[BlockRange],
    *,
    program_name: str = "program",
    listed: int | None = MAX_LISTED,
) -> RewriteReport:
    """Rewrite the F and S words of each operation's block range with its setpoint.

    Parameters
    ----------
    source : ProgramSource
        The program's bytes (a file opened ``"rb"``); read from its start, up to three times.
        Lines end in LF or CR LF (both kept) and are at most
        :data:`~supervisor.gcode.source.MAX_LINE_BYTES` long.
    target : ProgramTarget
        Where the new program is written: the same bytes but the new F and S numbers. When
        an error is raised part of it may have been written: discard it.
    setpoints : Mapping[str, OperationSetpoint]
        The setpoint of every operation named in ``ranges``.
    ranges : Sequence[BlockRange]
        The block ranges; an operation may have several, no two may share a line.
    program_name : str
        Name of the program in error messages (``"<name> line <n>"``).
    listed : int or None
        The most changes, and warnings, the report lists (None: all); all are counted.

    Returns
    -------
    RewriteReport
        The changes and the warnings (see the package docstring).

    Raises
    ------
    GcodeError
        When the program or a range cannot be rewritten safely (see the package docstring),
        a line is too long, or the program changed between two readings.
    """
    for r in ranges:
        if r.operation not in setpoints:
            raise GcodeError("map", r.describe(), f"no setpoint for operation {r.operation!r}")
    if not ranges:
        raise GcodeError("map", None, "give at least one OPERATION=N<start>:N<end>")
    located, walk, expected = _prepare(source, ranges, program_name)
    run = Pass(program_name, setpoints, Listing(listed), Listing(listed))
    _write(source, target, _Walk(run, located, *walk), expected)
    return RewriteReport(
        changes=run.changes.listed(),
        warnings=run.warnings.listed(),
        ranges=located,
        setpoints={r.operation: setpoints[r.operation] for r in ranges},
        change_count=run.changes.count,
        warning_count=run.warnings.count,
        changes_by_operation={r.operation: run.by_operation.get(r.operation, 0) for r in ranges},
    )


def _prepare(
    source: ProgramSource, ranges: Sequence[BlockRange], program_name: str
) -> tuple[tuple[ResolvedRange, ...], tuple[ContourSweep, int | None], tuple[int, int]]:
    """The readings before the rewrite: the ranges located, the contours, where to stop.

    Returns the ranges, the contours and the first unreadable line (the walk stops there),
    and the program's lines and bytes. The scan's cycles and the index of the block numbers
    they name are dropped here, once the contours are built.
    """
    scan = scan_program(source, ranges, program_name)
    located = locate_ranges(scan.sightings, ranges)
    problem = scan.first_problem
    if problem is not None and problem.line <= located[-1].last_line:
        raise _unreadable(problem, program_name)
    index = scan.cycles.named()
    if index.numbers:
        first_lines(source, index, program_name)
    stop = problem.line if problem is not None else None
    return located, (ContourSweep.of(scan.cycles, index), stop), (scan.lines, scan.size_bytes)


def _unreadable(block: Block, program_name: str) -> GcodeError:
    return GcodeError(
        f"{program_name} line {block.line}",
        block.text.strip(),
        f"cannot be read: {block.problem}; every line up to the end of the last range "
        "must be plain G-code, so that its modes and flow are certain",
    )


def rewrite_program(
    text: str,
    setpoints: Mapping[str, OperationSetpoint],
    ranges: Sequence[BlockRange],
    *,
    program_name: str = "program",
    listed: int | None = None,
) -> RewriteResult:
    """:func:`rewrite_stream` on a program in memory: the new text with the report.

    ``text`` is encoded as UTF-8 with ``surrogateescape`` (the text of a program's bytes
    decoded so) and the new program decoded back. Every change and warning is listed unless
    ``listed`` is given.

    Notes
    -----
    Under G95 an F word becomes ``f`` [mm/rev]; under G94 ``f · n`` [mm/min] with
    ``n = 1000 v / (π D)`` [rpm] at the operation's diameter D. Under G96 an S word becomes
    ``v`` [m/min]; under G97 ``n`` [rpm]. Values are rounded down (package docstring).
    """
    target = io.BytesIO()
    report = rewrite_stream(
        io.BytesIO(text.encode(ENCODING, BYTES)),
        target,
        setpoints,
        ranges,
        program_name=program_name,
        listed=listed,
    )
    fields = {name: getattr(report, name) for name in RewriteReport.__dataclass_fields__}
    return RewriteResult(text=target.getvalue().decode(ENCODING, BYTES), **fields)


@dataclass
class _Walk:
    """The walk along the program (mutable: local to one rewrite)."""

    run: Pass
    located: tuple[ResolvedRange, ...]
    contours: ContourSweep
    stop: int | None  # the first unreadable line (after the last range): the walk ends there
    at: int = 0  # index of the range the walk is in or before
    progress: list[Progress] = field(init=False)

    def __post_init__(self) -> None:
        self.progress = [Progress(r) for r in self.located]

    def range_of(self, line: int) -> Progress | None:
        """The range ``line`` is in (lines asked in increasing order)."""
        while self.at < len(self.located) and self.located[self.at].last_line < line:
            self.at += 1
        if self.at < len(self.located) and self.located[self.at].first_line <= line:
            return self.progress[self.at]
        return None

    def done(self, line: int) -> bool:
        """Whether nothing more can change or be warned about from ``line`` on."""
        if self.stop is not None and line >= self.stop:
            return True
        pending = self.run.pending_feed is not None or self.run.pending_speed is not None
        return line > self.located[-1].last_line and not pending


def _write(
    source: ProgramSource, target: ProgramTarget, walk: _Walk, expected: tuple[int, int]
) -> None:
    """Walk the program, writing each line: rewritten inside the ranges, else as read."""
    state = _unknown("no {names} before it", 0)
    lines = size = 0
    walking = True
    for line in read_lines(source, walk.run.program):
        lines, size = line.number, size + len(line.raw)
        walking = walking and not walk.done(line.number)
        if not walking:
            target.write(line.raw)
            continue
        block = read_block(line.text, line.ending, line.number)
        state = _enter(state, block)
        carry_over(walk.run, state, block)
        progress = walk.range_of(line.number)
        if progress is not None:
            rewrite_block(walk.run, state, block, progress, walk.contours.cycle_at(line.number))
            if line.number == progress.resolved.last_line:
                close_range(walk.run, state, progress)
        state = _leave(state, block)
        target.write(_edited(line, walk.run.take_edits()))
    if (lines, size) != expected:
        raise GcodeError(
            walk.run.program,
            f"{expected[0]} lines, {expected[1]} bytes",
            f"changed while it was read (now {lines} lines, {size} bytes); read it again",
        )


def _edited(line: Line, edits: list[tuple[int, int, str]]) -> bytes:
    """The line with its edits (start, end, new text); the bytes as read when there are none."""
    if not edits:
        return line.raw
    text = line.text
    for start, end, new in sorted(edits, reverse=True):
        text = text[:start] + new + text[end:]
    return (text + line.ending).encode(ENCODING, BYTES)
