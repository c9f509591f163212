"""A program read back into moves, with the project's G-code reader (:mod:`supervisor.gcode`).

The verification sweeps what was written, not what was meant: every line goes through
:func:`supervisor.gcode.lexer.parse_program`, and a line it cannot read is an error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from models.errors import InputError
from supervisor.gcode.lexer import parse_program


@dataclass(frozen=True)
class Segment:
    """One move: rapid (``G0``) or feed (``G1``-``G3``) from ``start`` to ``end`` [mm]."""

    tool: int
    rapid: bool
    start: tuple[float, float, float]
    end: tuple[float, float, float]
    feed_mm_min: float
    centre: tuple[float, float] | None = None
    ccw: bool = False

    def length_mm(self) -> float:
        """Path length [mm] (an arc's, for G2/G3)."""
        if self.centre is None:
            return math.dist(self.start, self.end)
        a0, a1, _ = self.sweep()
        r = math.hypot(self.start[0] - self.centre[0], self.start[1] - self.centre[1])
        return math.hypot(r * abs(a1 - a0), self.end[2] - self.start[2])

    def sweep(self) -> tuple[float, float, float]:
        """Start and end angle of an arc [rad] (end unwrapped in its direction), radius."""
        assert self.centre is not None
        cx, cy = self.centre
        a0 = math.atan2(self.start[1] - cy, self.start[0] - cx)
        a1 = math.atan2(self.end[1] - cy, self.end[0] - cx)
        if self.ccw and a1 <= a0:
            a1 += 2 * math.pi
        if not self.ccw and a1 >= a0:
            a1 -= 2 * math.pi
        return a0, a1, math.hypot(self.start[0] - cx, self.start[1] - cy)

    def points(self, step_mm: float) -> NDArray[np.float64]:
        """Points along the move at most ``step_mm`` apart, ends included (n, 3)."""
        n = max(1, math.ceil(self.length_mm() / step_mm))
        t = np.linspace(0.0, 1.0, n + 1)
        z = self.start[2] + t * (self.end[2] - self.start[2])
        if self.centre is None:
            x = self.start[0] + t * (self.end[0] - self.start[0])
            y = self.start[1] + t * (self.end[1] - self.start[1])
        else:
            a0, a1, r = self.sweep()
            a = a0 + t * (a1 - a0)
            x = self.centre[0] + r * np.cos(a)
            y = self.centre[1] + r * np.sin(a)
        return np.column_stack((x, y, z))


def read_moves(text: str) -> list[Segment]:
    """The moves of a program written by :mod:`supervisor.cam.program`.

    Raises
    ------
    InputError
        A line the reader cannot read, or an arc whose radius differs at its two ends.
    """
    x = y = 0.0
    z = math.inf
    feed = 0.0
    tool = 0
    motion = 0
    out: list[Segment] = []
    for block in parse_program(text):
        if block.problem:
            raise InputError(f"program line {block.line}", block.text, block.problem)
        # the number as written to a float: the same value as through its Decimal
        words = {w.letter: float(w.number) for w in block.words}
        if "T" in words:
            tool = int(words["T"])
        if "F" in words:
            feed = words["F"]
        for w in block.words:
            if w.letter == "G" and int(w.value) in (0, 1, 2, 3):
                motion = int(w.value)
        if not any(k in words for k in "XYZ"):
            continue
        nx, ny, nz = words.get("X", x), words.get("Y", y), words.get("Z", z)
        start = (x, y, z)
        if motion in (2, 3):
            centre = (x + words.get("I", 0.0), y + words.get("J", 0.0))
            r0 = math.hypot(x - centre[0], y - centre[1])
            r1 = math.hypot(nx - centre[0], ny - centre[1])
            if abs(r0 - r1) > 1e-3:
                raise InputError(
                    f"program line {block.line}", block.text, "arc ends off its circle"
                )
            out.append(Segment(tool, False, start, (nx, ny, nz), feed, centre, motion == 3))
        else:
            out.append(Segment(tool, motion == 0, start, (nx, ny, nz), feed))
        x, y, z = nx, ny, nz
    return out
