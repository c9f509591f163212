"""The contour blocks (P to Q) of the G70-G73 cycles, as line intervals swept in program order.

A cycle ``G71 P150 Q180`` names the first and last blocks of its contour by their numbers;
the contour is the lines from the first line numbered ``N150`` to the first numbered ``N180``
(either may come before the cycle, as a ``G70`` finishing pass's does). A line inside several
contours belongs to the first of their cycles in the program. Only the cycles and their
intervals are kept, never a table of every line.
"""

from __future__ import annotations

import bisect
import heapq
import re
from array import array
from collections.abc import Container
from dataclasses import dataclass, field
from decimal import Decimal
from typing import NamedTuple

from supervisor.gcode.lexer import Block

_CONTOUR_CYCLES = {Decimal(70), Decimal(71), Decimal(72), Decimal(73)}
#: The largest P or Q kept (an 8-byte integer's); a larger one names no block.
_INT64_MAX = (1 << 63) - 1
#: Where a block number may be in a line: a superset of the lexer's N words (comments too).
_N_WORD = re.compile(r"[Nn][ \t]*([+-]?(?:\d+(?:\.\d*)?|\.\d+))")


class Cycle(NamedTuple):
    """A G70-G73 cycle: its line and the block numbers of its contour's first and last block."""

    line: int
    first: int
    last: int


def cycle_of(block: Block) -> Cycle | None:
    """The cycle ``block`` starts, if it is a readable G70-G73 block with P and Q words.

    A P or Q beyond 18 digits (no control's block number) is taken to name no block (-1).
    """
    p, q = block.word("P"), block.word("Q")
    if block.problem or p is None or q is None or not set(block.codes("G")) & _CONTOUR_CYCLES:
        return None
    return Cycle(block.line, _named(p.value), _named(q.value))


def _named(value: Decimal) -> int:
    number = int(value)
    return number if 0 <= number <= _INT64_MAX else -1


def may_number(text: str, numbers: Container[int]) -> bool:
    """Whether ``text`` may be a block numbered one of ``numbers`` (a cheap test before lexing)."""
    for found in _N_WORD.finditer(text):
        value = Decimal(found.group(1))
        if value == value.to_integral_value() and int(value) in numbers:
            return True
    return False


@dataclass
class Cycles:
    """The cycles of a program in program order: three 8-byte numbers each, no objects.

    Mutable, local to one scan.
    """

    lines: array[int] = field(default_factory=lambda: array("q"))
    firsts: array[int] = field(default_factory=lambda: array("q"))
    lasts: array[int] = field(default_factory=lambda: array("q"))

    def add(self, cycle: Cycle) -> None:
        """Append ``cycle`` (the next in the program)."""
        self.lines.append(cycle.line)
        self.firsts.append(cycle.first)
        self.lasts.append(cycle.last)

    def __len__(self) -> int:
        """How many cycles."""
        return len(self.lines)

    def named(self) -> NumberIndex:
        """The block numbers the cycles name, each not yet seen on a line."""
        numbers = array("q", sorted({*self.firsts, *self.lasts} - {-1}))
        return NumberIndex(numbers, array("q", [-1]) * len(numbers))


@dataclass
class NumberIndex:
    """The first line of some block numbers: sorted numbers, their lines (-1: not seen).

    Mutable, local to one rewrite: filled by :func:`supervisor.gcode.scan.first_lines`.
    """

    numbers: array[int]
    lines: array[int]

    def _at(self, number: object) -> int | None:
        if not isinstance(number, int):
            return None
        at = bisect.bisect_left(self.numbers, number)
        return at if at < len(self.numbers) and self.numbers[at] == number else None

    def __contains__(self, number: object) -> bool:
        """Whether ``number`` is one of the numbers."""
        return self._at(number) is not None

    def see(self, number: int, line: int) -> None:
        """Block ``number`` is on ``line``: kept if it is the first (and a number of these)."""
        at = self._at(number)
        if at is not None and self.lines[at] < 0:
            self.lines[at] = line

    def get(self, number: int) -> int | None:
        """The first line of block ``number``, or None."""
        at = self._at(number)
        return None if at is None or self.lines[at] < 0 else self.lines[at]


@dataclass
class ContourSweep:
    """Which cycle's contour each line is in, asked for lines in increasing order.

    Mutable, local to one rewrite. The contours (first line, last line, cycle line) are
    arrays sorted by first line; only those open at the line asked are in a heap.
    """

    firsts: array[int]
    lasts: array[int]
    cycles: array[int]
    _next: int = 0
    _open: list[tuple[int, int]] = field(default_factory=list)  # cycle line, last line

    @classmethod
    def of(cls, cycles: Cycles, index: NumberIndex) -> ContourSweep:
        """The contours of ``cycles`` whose first and last blocks are both in the program."""
        firsts, lasts, lines = array("q"), array("q"), array("q")
        for line, p, q in zip(cycles.lines, cycles.firsts, cycles.lasts, strict=True):
            first, last = index.get(p), index.get(q)
            if first is not None and last is not None and first <= last:
                firsts.append(first)
                lasts.append(last)
                lines.append(line)
        if all(a <= b for a, b in zip(firsts, firsts[1:], strict=False)):
            return cls(firsts, lasts, lines)  # as programs mostly are: no sort, no copy
        order = sorted(range(len(firsts)), key=firsts.__getitem__)
        return cls(
            array("q", (firsts[i] for i in order)),
            array("q", (lasts[i] for i in order)),
            array("q", (lines[i] for i in order)),
        )

    def cycle_at(self, line: int) -> int | None:
        """The line of the first cycle (in the program) whose contour holds ``line``, or None."""
        while self._next < len(self.firsts) and self.firsts[self._next] <= line:
            heapq.heappush(self._open, (self.cycles[self._next], self.lasts[self._next]))
            self._next += 1
        while self._open and self._open[0][1] < line:
            heapq.heappop(self._open)
        return self._open[0][0] if self._open else None
