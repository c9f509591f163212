"""The contour blocks (P to Q) of the G70-G73 cycles, as line intervals swept in program order.

A cycle ``G71 P150 Q180`` names the first and last blocks of its contour by their numbers;
the contour is the lines from the first line numbered ``N150`` to the first numbered ``N180``
(either may come before the cycle, as a ``G70`` finishing pass's does). A line inside several
contours belongs to the first of their cycles in the program. Only the cycles and their
intervals are kept, never a table of every line.
"""

from __future__ import annotations

import heapq
import re
from collections.abc import Container, Iterable, Mapping
from dataclasses import dataclass, field
from decimal import Decimal

from supervisor.gcode.lexer import Block

_CONTOUR_CYCLES = {Decimal(70), Decimal(71), Decimal(72), Decimal(73)}
#: Where a block number may be in a line: a superset of the lexer's N words (comments too).
_N_WORD = re.compile(r"[Nn][ \t]*([+-]?(?:\d+(?:\.\d*)?|\.\d+))")


@dataclass(frozen=True)
class Cycle:
    """A G70-G73 cycle: its line and the block numbers of its contour's first and last block."""

    line: int
    first: int
    last: int


def cycle_of(block: Block) -> Cycle | None:
    """The cycle ``block`` starts, if it is a readable G70-G73 block with P and Q words."""
    p, q = block.word("P"), block.word("Q")
    if block.problem or p is None or q is None or not set(block.codes("G")) & _CONTOUR_CYCLES:
        return None
    return Cycle(block.line, int(p.value), int(q.value))


def may_number(text: str, numbers: Container[int]) -> bool:
    """Whether ``text`` may be a block numbered one of ``numbers`` (a cheap test before lexing)."""
    for found in _N_WORD.finditer(text):
        value = Decimal(found.group(1))
        if value == value.to_integral_value() and int(value) in numbers:
            return True
    return False


@dataclass
class ContourSweep:
    """Which cycle's contour each line is in, asked for lines in increasing order.

    Mutable, local to one rewrite. Built from the cycles in program order and the first line of
    each block number they name (:func:`supervisor.gcode.scan.first_lines`).
    """

    intervals: list[tuple[int, int, int]]  # first line, last line, cycle line; by first line
    _next: int = 0
    _open: list[tuple[int, int]] = field(default_factory=list)  # cycle line, last line

    @classmethod
    def of(cls, cycles: Iterable[Cycle], line_of: Mapping[int, int]) -> ContourSweep:
        """The contours of ``cycles`` whose first and last blocks are both in the program."""
        intervals = []
        for cycle in cycles:
            first, last = line_of.get(cycle.first), line_of.get(cycle.last)
            if first is not None and last is not None and first <= last:
                intervals.append((first, last, cycle.line))
        intervals.sort()
        return cls(intervals)

    def cycle_at(self, line: int) -> int | None:
        """The line of the first cycle (in the program) whose contour holds ``line``, or None."""
        while self._next < len(self.intervals) and self.intervals[self._next][0] <= line:
            _, last, cycle = self.intervals[self._next]
            heapq.heappush(self._open, (cycle, last))
            self._next += 1
        while self._open and self._open[0][1] < line:
            heapq.heappop(self._open)
        return self._open[0][0] if self._open else None
