"""The operations' setpoints and their block ranges (``OP=N100:N200``), located in a program."""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field

from models.kinematics import turning_spindle_rpm
from supervisor.gcode.errors import GcodeError
from supervisor.gcode.lexer import Block

_RANGE = re.compile(r"\s*[Nn]?(\d+)\s*:\s*[Nn]?(\d+)\s*")
#: The most lines an error lists for a block number found on several.
SHOWN_LINES = 10


@dataclass(frozen=True)
class OperationSetpoint:
    """The setpoint of one turning operation, as the program needs it.

    Parameters
    ----------
    name : str
        Operation name.
    feed_mm_rev : float
        Feed per revolution [mm/rev].
    speed_m_min : float
        Cutting (surface) speed [m/min].
    workpiece_diameter_mm : float
        Workpiece diameter of the operation [mm]: the diameter at which the spindle speed
        and the feed per minute are computed.
    """

    name: str
    feed_mm_rev: float
    speed_m_min: float
    workpiece_diameter_mm: float

    def __post_init__(self) -> None:
        """Check that every number is positive and finite."""
        for key in ("feed_mm_rev", "speed_m_min", "workpiece_diameter_mm"):
            value = getattr(self, key)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise GcodeError(f"{self.name}.{key}", value, "must be a positive finite number")

    @property
    def spindle_rpm(self) -> float:
        """Spindle speed at the operation's diameter, ``1000 v / (π D)`` [rpm]."""
        return turning_spindle_rpm(self.speed_m_min, self.workpiece_diameter_mm)


@dataclass(frozen=True)
class BlockRange:
    """The blocks of one operation: from block ``N start`` to block ``N end``, both included.

    Parameters
    ----------
    operation : str
        Operation name.
    start, end : int
        Block numbers (N) of the first and last block.
    """

    operation: str
    start: int
    end: int

    def describe(self) -> str:
        """``rough-od=N100:N200``."""
        return f"{self.operation}=N{self.start}:N{self.end}"


def parse_range(text: str) -> BlockRange:
    """Read ``OP=N100:N200`` (the ``N`` letters optional) as a :class:`BlockRange`.

    Raises
    ------
    GcodeError
        With field ``"map"`` if the text is not of that form.
    """
    name, sep, blocks = text.rpartition("=")
    found = _RANGE.fullmatch(blocks)
    if not sep or not name.strip() or found is None:
        raise GcodeError("map", text, "must be OPERATION=N<start>:N<end>, e.g. rough-od=N100:N200")
    return BlockRange(name.strip(), int(found.group(1)), int(found.group(2)))


@dataclass(frozen=True)
class ResolvedRange:
    """A block range located in the program.

    Parameters
    ----------
    range : BlockRange
        The range as given.
    first_line, last_line : int
        Line numbers of its first and last block.
    """

    range: BlockRange
    first_line: int
    last_line: int


def resolve_ranges(
    blocks: Sequence[Block], ranges: Sequence[BlockRange]
) -> tuple[ResolvedRange, ...]:
    """Locate each range by its block numbers, in the order they appear in the program.

    Raises
    ------
    GcodeError
        With field ``"map"``: no range, a block number missing or found on several lines,
        the end before the start, two ranges sharing a line.
    """
    sightings = Sightings()
    for block in blocks:
        if block.number is not None:
            sightings.add(block.number, block.line)
    return locate_ranges(sightings, ranges)


@dataclass
class Sightings:
    """The lines of some block numbers: the first :data:`SHOWN_LINES` each, and how many.

    Mutable, local to one scan of a program.
    """

    lines: dict[int, list[int]] = field(default_factory=dict)
    counts: dict[int, int] = field(default_factory=dict)

    def add(self, number: int, line: int) -> None:
        """Block ``number`` is on ``line``."""
        found = self.lines.setdefault(number, [])
        if len(found) < SHOWN_LINES:
            found.append(line)
        self.counts[number] = self.counts.get(number, 0) + 1


def locate_ranges(sightings: Sightings, ranges: Sequence[BlockRange]) -> tuple[ResolvedRange, ...]:
    """Locate each range from the lines its block numbers were seen on (:func:`resolve_ranges`).

    Raises
    ------
    GcodeError
        As :func:`resolve_ranges`.
    """
    if not ranges:
        raise GcodeError("map", None, "give at least one OPERATION=N<start>:N<end>")
    located = []
    for r in ranges:
        first, last = _line_of(sightings, r.start, r), _line_of(sightings, r.end, r)
        if last < first:
            raise GcodeError(
                "map",
                r.describe(),
                f"block N{r.end} (line {last}) comes before block N{r.start} (line {first})",
            )
        located.append(ResolvedRange(r, first, last))
    located.sort(key=lambda x: x.first_line)
    for before, after in zip(located, located[1:], strict=False):
        if after.first_line <= before.last_line:
            raise GcodeError(
                "map",
                after.range.describe(),
                f"lines {after.first_line}-{after.last_line} overlap "
                f"{before.range.describe()} (lines {before.first_line}-{before.last_line})",
            )
    return tuple(located)


def _line_of(sightings: Sightings, number: int, r: BlockRange) -> int:
    found = sightings.lines.get(number, [])
    if not found:
        raise GcodeError("map", r.describe(), f"no block N{number} in the program")
    if len(found) > 1:
        where = ", ".join(str(n) for n in found)
        more = sightings.counts[number] - len(found)
        where += f" and {more} more" if more else ""
        raise GcodeError("map", r.describe(), f"block N{number} is on several lines ({where})")
    return found[0]
