"""The passes before the rewrite: where the ranges are, what cannot be read, the contours.

The rewrite needs to know things further down the program than the line it is at: where each
range ends (a block number given twice is refused, wherever the second one is), whether any
line up to the end of the last range cannot be read, and which lines are the contour of a
G70-G73 cycle (a ``G70`` names blocks before it). :func:`scan_program` reads the program once
for all of it and keeps only what the rewrite needs: the lines of the mapped block numbers,
the first unreadable line, the cycles; :func:`first_lines` reads it again, lexing only the lines
that may carry a block number a cycle names.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from supervisor.gcode.contours import Cycles, NumberIndex, cycle_of, may_number
from supervisor.gcode.lexer import Block, read_block
from supervisor.gcode.ranges import BlockRange, Sightings
from supervisor.gcode.source import ProgramSource, read_lines


@dataclass(frozen=True)
class Scan:
    """What one reading of a program found.

    Parameters
    ----------
    sightings : Sightings
        The lines of the block numbers the ranges name.
    first_problem : Block or None
        The first line that cannot be read.
    cycles : Cycles
        The G70-G73 cycles with P and Q, in program order.
    lines : int
        How many lines the program has.
    size_bytes : int
        Its size [bytes].
    """

    sightings: Sightings
    first_problem: Block | None
    cycles: Cycles
    lines: int
    size_bytes: int


def scan_program(source: ProgramSource, ranges: Sequence[BlockRange], program_name: str) -> Scan:
    """Read the program once: the mapped block numbers, the first unreadable line, the cycles.

    Raises
    ------
    GcodeError
        A line too long (:func:`supervisor.gcode.source.read_lines`).
    """
    wanted = {n for r in ranges for n in (r.start, r.end)}
    sightings = Sightings()
    first_problem: Block | None = None
    cycles = Cycles()
    lines = size = 0
    for line in read_lines(source, program_name):
        block = read_block(line.text, line.ending, line.number)
        lines, size = line.number, size + len(line.raw)
        if block.number is not None and block.number in wanted:
            sightings.add(block.number, block.line)
        if block.problem and first_problem is None:
            first_problem = block
        if (cycle := cycle_of(block)) is not None:
            cycles.add(cycle)
    return Scan(sightings, first_problem, cycles, lines, size)


def first_lines(source: ProgramSource, index: NumberIndex, program_name: str) -> NumberIndex:
    """``index`` with the first line of each of its block numbers, on a readable line."""
    for line in read_lines(source, program_name):
        if not may_number(line.text, index):
            continue
        block = read_block(line.text, line.ending, line.number)
        if block.number is not None and not block.problem:
            index.see(block.number, block.line)
    return index
