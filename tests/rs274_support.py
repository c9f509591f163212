"""LinuxCNC's standalone G-code interpreter ``rs274`` as a reader of the programs we write.

``rs274`` (Debian package ``linuxcnc-uspace``, installed by ``.ci/run``) reads a program and
prints its canonical machining commands (``STRAIGHT_TRAVERSE``, ``STRAIGHT_FEED``,
``ARC_FEED``, ``SET_FEED_RATE`` ...), one a line, or stops at the first line it rejects and
exits 1. The cycle time is summed here from those commands: feed moves at the feed rate in
force, rapids at :data:`supervisor.cam.verify.RAPID_MM_MIN` (the project's assumption, the
plan gives none). The first move, from wherever the machine stands, is not counted (as
:func:`supervisor.cam.verify.machining_time` does not).
"""

from __future__ import annotations

import math
import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest

from supervisor.cam.verify import RAPID_MM_MIN

RS274 = shutil.which("rs274")
#: Why the tests that need it are skipped when it is absent.
MISSING = "LinuxCNC's rs274 is not installed (Debian package linuxcnc-uspace; .ci/run installs it)"
needs_rs274 = pytest.mark.skipif(RS274 is None, reason=MISSING)

_CALL = re.compile(r"^\s*\d+\s+N\S*\s+([A-Z_]+)\((.*)\)\s*$")


@dataclass(frozen=True)
class Canon:
    """What ``rs274`` made of a program."""

    feed_min: float
    rapid_min: float
    commands: dict[str, int]

    @property
    def cycle_min(self) -> float:
        """Feed and rapid time [min]."""
        return self.feed_min + self.rapid_min


def run_rs274(program: str, folder: Path, tools: dict[int, float]) -> Canon:
    """Run ``rs274`` on ``program`` with a tool table of ``tools`` (number: diameter mm).

    Fails the test with rs274's own message when it rejects a line.
    """
    assert RS274 is not None, MISSING
    source, canon, table = folder / "rs274.ngc", folder / "rs274.canon", folder / "rs274.tbl"
    source.write_text(program)
    table.write_text("".join(f"T{n} P{n} D{d} Z0 ;\n" for n, d in sorted(tools.items())))
    done = subprocess.run(
        [RS274, "-g", "-t", str(table), str(source), str(canon)],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    said = (done.stdout + done.stderr).strip()
    assert done.returncode == 0 and said == "executing", f"rs274 rejected the program: {said}"
    return parse_canon(canon.read_text())


def rs274_rejects(program: str, folder: Path) -> str:
    """rs274's message for a program it refuses (the test fails if it reads it)."""
    assert RS274 is not None, MISSING
    source = folder / "rs274.ngc"
    source.write_text(program)
    done = subprocess.run(
        [RS274, "-g", str(source), str(folder / "rs274.canon")],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode != 0, "rs274 read the program"
    return (done.stdout + done.stderr).replace("executing", "").strip()


def parse_canon(text: str) -> Canon:
    """Feed and rapid time of rs274's canonical commands (module docstring)."""
    feed_rate = 0.0
    here: tuple[float, float, float] | None = None
    feed = rapid = 0.0
    counts: dict[str, int] = {}
    for line in text.splitlines():
        match = _CALL.match(line)
        if match is None:
            continue
        name, args = match.group(1), match.group(2)
        counts[name] = counts.get(name, 0) + 1
        if name == "SET_FEED_RATE":
            feed_rate = float(args)
            continue
        if name not in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "ARC_FEED"):
            continue
        values = [float(v) for v in args.split(",")]
        if name == "ARC_FEED":  # XY plane: x, y, centre x, centre y, turns, z, ...
            end = (values[0], values[1], values[5])
            length = _arc_length(here, end, (values[2], values[3]), int(values[4]))
        else:
            end = (values[0], values[1], values[2])
            length = math.dist(here, end) if here is not None else 0.0
        if here is not None:
            if name == "STRAIGHT_TRAVERSE":
                rapid += length / RAPID_MM_MIN
            else:
                feed += length / feed_rate
        here = end
    return Canon(feed, rapid, counts)


def _arc_length(
    start: tuple[float, float, float] | None,
    end: tuple[float, float, float],
    centre: tuple[float, float],
    turns: int,
) -> float:
    if start is None:
        return 0.0
    cx, cy = centre
    r = math.hypot(start[0] - cx, start[1] - cy)
    a0 = math.atan2(start[1] - cy, start[0] - cx)
    a1 = math.atan2(end[1] - cy, end[0] - cx)
    if turns > 0:  # counter-clockwise
        sweep = (a1 - a0) % (2 * math.pi) or 2 * math.pi
        sweep += 2 * math.pi * (turns - 1)
    else:
        sweep = (a0 - a1) % (2 * math.pi) or 2 * math.pi
        sweep += 2 * math.pi * (-turns - 1)
    return math.hypot(r * sweep, end[2] - start[2])
