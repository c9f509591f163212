"""Rewrite the feed (F) and spindle speed (S) words of a lathe program with the setpoints.

A program is read line by line in the ISO 6983 / Fanuc style: an optional block number
``N``, words (a letter and a number, several G codes per block allowed), comments in
parentheses and after ``;``, ``%`` tape-marker lines, blank lines, an optional-skip ``/`` at
the start of a block. Each operation is mapped to the lines from its block ``N_start`` to its
block ``N_end`` (both included, unnumbered lines in between included). Inside those lines
every F word gets the operation's feed and every S word its spindle speed; nothing else
changes: every other byte, the spacing, the comments and the line endings are kept.

Dialect. ISO 6983 feed and spindle modes as on Okuma and Fanuc systems B/C with the lathe
spindle clamp: ``G94`` feed per minute [mm/min], ``G95`` feed per revolution [mm/rev],
``G96`` constant surface speed (S in m/min), ``G97`` constant spindle speed (S in rpm),
``G50 S`` (or ``G92 S``) the maximum spindle speed under G96, ``G20``/``G21`` inch/mm.
Fanuc lathe system A and Haas select the feed mode with ``G98``/``G99`` and use ``G94`` as a
face-turning cycle: a ``G98``/``G99``, or a ``G94`` with axis words and no ``G00``-``G03``,
makes the feed mode unknown until the next plain ``G94``/``G95``.

What is refused (:class:`GcodeError`), so that a program is never rewritten on a guess:

- a line that cannot be read (macro variables ``#``, expressions ``[ ]``, ``IF``/``GOTO``/
  ``WHILE``, an unclosed comment, two F or S words in one block) anywhere up to the end of
  the last range: the modes and the flow of the program would not be certain;
- an F word whose feed mode, or an S word whose spindle mode, is not known where it stands
  (no G94/G95 or G96/G97 before it, a subprogram call or program end since, a mode set in
  an optional-skip block), an F or S under G20 (inches) or with no G21 before it, an F under
  G93 (inverse time);
- a spindle clamp (G50 S or G92 S) in force in the range below the spindle speed the new
  setpoint needs at the operation's diameter, ``n = 1000 v / (π D)`` (Sandvik Coromant,
  turning formulas). The control would clamp the spindle and cut slower than the setpoint,
  and a part report would be credited to a setpoint that was not run. It is refused under
  G97 too (Fanuc ignores G50 under G97, Haas clamps): raise the clamp, or give the plan's
  machine ``max_spindle_rpm`` so the optimiser respects it;
- a block N missing or given more than once, a range ending before it starts, overlapping
  ranges.

What is left alone, with a warning in the result: the F of a threading block (G32, G33, G34,
G76, G92 with F and the G32-G34/G92 blocks after it: the F is the lead) and of a tapping
cycle (G84, G88: the F is the pitch); the F and S words in the contour blocks (P to Q) of a
G70-G73 cycle (they apply to the G70 finishing pass, not to the roughing cycle). Warnings
also report a range with no F or no S word (nothing is invented: the feed or speed in force
before the range stays), a subprogram call inside a range (its words are not rewritten), a
G94 feed under G96 (the feed per revolution is the setpoint only at the operation's
diameter), and a new F or S that stays in force after the range for a cutting move.

Numbers. The values are rounded *down* (never faster than the verified setpoint) to a fixed
precision: F in mm/rev 4 decimals, F in mm/min 1 decimal, S (m/min or rpm) whole numbers.
Trailing zeros are dropped, then the word keeps the style of the original: at least as many
decimals as it had (zeros added), a trailing point if it had one (``S200.`` → ``S230.``), no
leading zero if it had none (``F.25`` → ``F.325``), its letter case and any space after the
letter. An F in mm/rev always has a decimal point (on Fanuc controls an F without one can
mean hundredths of a millimetre per revolution). ``F0.25`` → ``F0.3248``, ``S200`` → ``S230``.

References
----------
.. [1] ISO 6983-1:2009, Numerical control of machines, program format and addresses.
.. [2] Fanuc Series 0i-TF operator's manual (B-64604EN), G code list (systems A, B, C),
   constant surface speed control and maximum spindle speed clamp, multiple repetitive
   cycles G70-G73.
.. [3] Sandvik Coromant, Metal cutting formulas, turning: ``n = 1000 vc / (π Dm)``,
   ``vf = fn · n``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from decimal import ROUND_FLOOR, Decimal
from typing import Literal

from models.errors import InputError
from models.kinematics import turning_spindle_rpm
from supervisor.errors import SupervisorError

#: Decimal places written for a feed per revolution [mm/rev].
FEED_MM_REV_PLACES = 4
#: Decimal places written for a feed per minute [mm/min].
FEED_MM_MIN_PLACES = 1
#: Decimal places written for a spindle speed (m/min under G96, rpm under G97).
SPEED_PLACES = 0

Quantity = Literal["feed_mm_rev", "feed_rate_mm_min", "speed_m_min", "spindle_rpm"]

_NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)")
_RANGE = re.compile(r"\s*[Nn]?(\d+)\s*:\s*[Nn]?(\d+)\s*")
_AXES = frozenset("XYZUVWABC")
_BOM = "\ufeff"


class GcodeError(SupervisorError, InputError):
    """A program or a block range that cannot be rewritten safely.

    ``field`` is ``"<program> line <n>"`` for a line of the program, ``"map"`` for a block
    range (its ``value`` is the range as given), ``"<operation>.<name>"`` for a setpoint.
    """


# --------------------------------------------------------------------------------------------
# reading a program


@dataclass(frozen=True)
class Word:
    """One word of a block: a letter and a number.

    Parameters
    ----------
    letter : str
        The address letter, upper case (``O`` for a ``:`` program number).
    number : str
        The number as written (``"0.25"``, ``".3"``, ``"200."``).
    value : decimal.Decimal
        The number's value.
    start : int
        Index of the letter in the line (0-based).
    number_start : int
        Index of the number's first character (after any spaces following the letter).
    end : int
        Index just after the number.
    """

    letter: str
    number: str
    value: Decimal
    start: int
    number_start: int
    end: int


@dataclass(frozen=True)
class Block:
    """One line of a program.

    Parameters
    ----------
    line : int
        Line number, from 1.
    text : str
        The line without its line ending.
    ending : str
        The line ending as found: LF, CR LF, or empty (a last line without one).
    words : tuple[Word, ...]
        The words, in order (those before the first unreadable character, if any).
    number : int or None
        The block number ``N``.
    optional_skip : bool
        Whether the block starts with ``/`` (skipped when block delete is on).
    marker : bool
        Whether the line is a ``%`` tape marker.
    problem : str or None
        Why the line cannot be read, or None.
    """

    line: int
    text: str
    ending: str
    words: tuple[Word, ...]
    number: int | None
    optional_skip: bool
    marker: bool
    problem: str | None

    def codes(self, letter: str) -> tuple[Decimal, ...]:
        """The values of the words with ``letter`` (e.g. every G code of the block)."""
        return tuple(w.value for w in self.words if w.letter == letter)

    def word(self, letter: str) -> Word | None:
        """The first word with ``letter``, or None."""
        return next((w for w in self.words if w.letter == letter), None)


def parse_program(text: str) -> tuple[Block, ...]:
    """Split a program into lines and read each into words.

    Lines end at LF; a CR before it belongs to the line ending. A line that cannot
    be read is kept with its ``problem``; the caller decides whether it matters.

    Parameters
    ----------
    text : str
        The program.

    Returns
    -------
    tuple[Block, ...]
        One block per line, in order; ``"".join(b.text + b.ending for b in blocks) == text``.
    """
    blocks = []
    for index, match in enumerate(re.finditer(r"[^\n]*\n|[^\n]+\Z", text)):
        raw = match.group()
        ending = "\r\n" if raw.endswith("\r\n") else "\n" if raw.endswith("\n") else ""
        blocks.append(_read_line(raw[: len(raw) - len(ending)], ending, index + 1))
    return tuple(blocks)


def _read_line(text: str, ending: str, line: int) -> Block:
    i = 1 if line == 1 and text.startswith(_BOM) else 0
    if text[i:].lstrip().startswith("%"):
        return Block(line, text, ending, (), None, False, True, None)
    words: list[Word] = []
    skip = False
    problem = None
    while i < len(text):
        char = text[i]
        if char.isspace():
            i += 1
        elif char == "(":
            close = text.find(")", i + 1)
            if close < 0:
                problem = f"the comment opened at column {i + 1} is not closed"
                break
            i = close + 1
        elif char == ";":
            break
        elif char == "/" and not words and not skip:
            skip = True
            i += 2 if text[i + 1 : i + 2].isdigit() else 1
        elif (char.isascii() and char.isalpha()) or char == ":":
            j = i + 1
            while j < len(text) and text[j] in " \t":
                j += 1
            found = _NUMBER.match(text, j)
            if found is None:
                problem = (
                    f"{char!r} at column {i + 1} is not followed by a number "
                    "(macro statements are not supported)"
                )
                break
            letter = "O" if char == ":" else char.upper()
            written = found.group()
            words.append(Word(letter, written, Decimal(written), i, j, found.end()))
            i = found.end()
        else:
            problem = (
                f"unexpected {char!r} at column {i + 1} "
                "(macro variables and expressions are not supported)"
            )
            break
    number, number_problem = _block_number(words)
    for letter in "FS":
        if sum(1 for w in words if w.letter == letter) > 1:
            number_problem = number_problem or f"two {letter} words in one block"
    return Block(line, text, ending, tuple(words), number, skip, False, problem or number_problem)


def _block_number(words: Sequence[Word]) -> tuple[int | None, str | None]:
    numbers = [w for w in words if w.letter == "N"]
    if not numbers:
        return None, None
    if len(numbers) > 1:
        return None, "two block numbers (N) in one block"
    value = numbers[0].value
    if value < 0 or value != value.to_integral_value():
        return None, f"block number N{numbers[0].number} is not a whole number"
    return int(value), None


# --------------------------------------------------------------------------------------------
# operations and ranges


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
    if not ranges:
        raise GcodeError("map", None, "give at least one OPERATION=N<start>:N<end>")
    lines: dict[int, list[int]] = {}
    for block in blocks:
        if block.number is not None:
            lines.setdefault(block.number, []).append(block.line)
    located = []
    for r in ranges:
        first, last = _line_of(lines, r.start, r), _line_of(lines, r.end, r)
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


def _line_of(lines: Mapping[int, list[int]], number: int, r: BlockRange) -> int:
    found = lines.get(number, [])
    if not found:
        raise GcodeError("map", r.describe(), f"no block N{number} in the program")
    if len(found) > 1:
        where = ", ".join(str(n) for n in found)
        raise GcodeError("map", r.describe(), f"block N{number} is on several lines ({where})")
    return found[0]


# --------------------------------------------------------------------------------------------
# the result


@dataclass(frozen=True)
class Change:
    """One rewritten word.

    Parameters
    ----------
    line : int
        Line number, from 1.
    column : int
        Column of the word's letter, from 1.
    operation : str
        The operation whose setpoint it carries.
    old, new : str
        The word before and after (letter, any space after it, number).
    quantity : {"feed_mm_rev", "feed_rate_mm_min", "speed_m_min", "spindle_rpm"}
        What the new number is.
    mode : str
        The mode it was written for (``G95``, ``G94``, ``G96``, ``G97``).
    """

    line: int
    column: int
    operation: str
    old: str
    new: str
    quantity: Quantity
    mode: str


@dataclass(frozen=True)
class Notice:
    """A warning: something the rewrite left as it was, or that the engineer should check.

    Parameters
    ----------
    line : int or None
        The line it is about, if one.
    operation : str
        The operation whose range it concerns.
    message : str
        What and why.
    """

    line: int | None
    operation: str
    message: str


@dataclass(frozen=True)
class RewriteResult:
    """The rewritten program, what changed, and the warnings.

    Parameters
    ----------
    text : str
        The new program: the input with only the F and S numbers of ``changes`` replaced.
    changes : tuple[Change, ...]
        Every rewritten word, in program order.
    warnings : tuple[Notice, ...]
        Every warning, in program order.
    ranges : tuple[ResolvedRange, ...]
        The ranges, in program order.
    setpoints : Mapping[str, OperationSetpoint]
        The setpoints written, by operation.
    """

    text: str
    changes: tuple[Change, ...]
    warnings: tuple[Notice, ...]
    ranges: tuple[ResolvedRange, ...]
    setpoints: Mapping[str, OperationSetpoint]


# --------------------------------------------------------------------------------------------
# modal state


@dataclass(frozen=True)
class _Mode:
    code: str | None  # "G95" ...; None when not known
    line: int  # where it was set or became unknown (0: program start)
    why: str  # when not known: why


@dataclass(frozen=True)
class _Clamp:
    rpm: float
    line: int
    word: str


@dataclass(frozen=True)
class _State:
    units: _Mode
    feed: _Mode
    spindle: _Mode
    clamps: tuple[_Clamp, ...] = ()  # every clamp that may be in force
    motion: str = ""  # "rapid", "cut", "thread" or "" (not known)
    cycle: str = ""  # "tap", "drill" or "" (none)
    last_feed: tuple[int, str] | None = None  # line and word of the F in force
    last_speed: tuple[int, str] | None = None


_GROUPS: dict[str, tuple[str, dict[Decimal, str]]] = {
    "units": ("G20 or G21", {Decimal(20): "G20", Decimal(21): "G21"}),
    "feed": ("G94 or G95", {Decimal(93): "G93", Decimal(94): "G94", Decimal(95): "G95"}),
    "spindle": ("G96 or G97", {Decimal(96): "G96", Decimal(97): "G97"}),
}
_MOTION = {Decimal(0): "rapid", Decimal(1): "cut", Decimal(2): "cut", Decimal(3): "cut"}
_THREADING = {Decimal(32), Decimal(33), Decimal(34)}
_CALLS = {("M", Decimal(98)), ("M", Decimal(198)), ("M", Decimal(97))}
_CALLS |= {("G", Decimal(65)), ("G", Decimal(66)), ("G", Decimal("66.1"))}
_ENDS = {("M", Decimal(2)), ("M", Decimal(30)), ("M", Decimal(99))}
_CLAMP_CODES = {Decimal(50), Decimal(92)}
_CONTOUR_CYCLES = {Decimal(70), Decimal(71), Decimal(72), Decimal(73)}
_CYCLE_CUTS = {Decimal(n) for n in (70, 71, 72, 73, 74, 75, 90)}


def _unknown(template: str, line: int) -> _State:
    """Every mode unknown; ``template`` has ``{names}`` for the codes that would set it."""
    modes = {
        group: _Mode(None, line, template.format(names=names))
        for group, (names, _) in _GROUPS.items()
    }
    return _State(units=modes["units"], feed=modes["feed"], spindle=modes["spindle"])


def _enter(state: _State, block: Block) -> _State:
    """The state in force for the words of ``block``: its own G codes apply to it."""
    g = set(block.codes("G"))
    n = block.line
    modes = {"units": state.units, "feed": state.feed, "spindle": state.spindle}
    for group, (_, codes) in _GROUPS.items():
        found = sorted({codes[c] for c in g if c in codes})
        if len(found) > 1:
            modes[group] = _Mode(None, n, f"{' and '.join(found)} are both in line {n}")
        elif found and block.optional_skip and modes[group].code != found[0]:
            modes[group] = _Mode(
                None, n, f"{found[0]} at line {n} is in an optional-skip (/) block"
            )
        elif found:
            modes[group] = _Mode(found[0], n, "")
    feed_codes = g & set(_GROUPS["feed"][1])
    has_axes = any(w.letter in _AXES for w in block.words)
    if Decimal(94) in g and has_axes and not g & set(_MOTION):
        modes["feed"] = _Mode(
            None,
            n,
            f"G94 at line {n} has axis words and no G00-G03: on Fanuc lathe G-code system A "
            "and Haas it is a face-turning cycle; state G94 or G95 in a block of its own",
        )
    for code in (Decimal(98), Decimal(99)):
        if code in g and not feed_codes:
            modes["feed"] = _Mode(
                None,
                n,
                f"G{code} at line {n} selects the feed mode on Fanuc lathe G-code system A and "
                "Haas (G98 per minute, G99 per revolution); this command reads only G94/G95: "
                "state G94 or G95 after it",
            )
    motion, cycle = state.motion, state.cycle
    moves = g & (set(_MOTION) | _THREADING)
    if moves:
        code = max(moves)
        motion, cycle = ("thread" if code in _THREADING else _MOTION[code]), ""
    if Decimal(92) in g and block.word("F") is not None:
        motion, cycle = "thread", ""
    if Decimal(80) in g:
        cycle = ""
    for code in g:
        if Decimal(81) <= code < Decimal(90):
            cycle = "tap" if int(code) in (84, 88) else "drill"
    clamps = state.clamps
    speed = block.word("S")
    if g & _CLAMP_CODES and speed is not None:
        clamp = _Clamp(float(speed.value), n, block.text[speed.start : speed.end])
        clamps = (*clamps, clamp) if block.optional_skip else (clamp,)
    return replace(
        state,
        units=modes["units"],
        feed=modes["feed"],
        spindle=modes["spindle"],
        clamps=clamps,
        motion=motion,
        cycle=cycle,
    )


def _leave(state: _State, block: Block) -> _State:
    """The state after ``block``: subprogram calls and program ends make every mode unknown."""
    n = block.line
    call = next((w for w in block.words if (w.letter, w.value) in _CALLS), None)
    end = next((w for w in block.words if (w.letter, w.value) in _ENDS), None)
    program = block.word("O")
    feed, speed = block.word("F"), block.word("S")
    if speed is not None and set(block.codes("G")) & _CLAMP_CODES:
        speed = None  # the spindle clamp
    last_feed = (n, _text(block, feed)) if feed else state.last_feed
    last_speed = (n, _text(block, speed)) if speed else state.last_speed
    if call is not None:
        after = _unknown(f"the call {_text(block, call)} at line {n} may have changed it", n)
    elif end is not None:
        after = _unknown(f"the program ended ({_text(block, end)}) at line {n}", n)
    elif program is not None:
        after = _unknown(f"no {{names}} since program {_text(block, program)} at line {n}", n)
    else:
        after = state
    return replace(after, last_feed=last_feed, last_speed=last_speed)


def _text(block: Block, word: Word) -> str:
    return block.text[word.start : word.end]


def _contours(blocks: Sequence[Block]) -> dict[int, int]:
    """Lines of the contour blocks (P to Q) of every G70-G73 cycle → line of the cycle."""
    line_of: dict[int, int] = {}
    for block in blocks:
        if block.number is not None and not block.problem:
            line_of.setdefault(block.number, block.line)
    inside: dict[int, int] = {}
    for block in blocks:
        p, q = block.word("P"), block.word("Q")
        if block.problem or p is None or q is None or not set(block.codes("G")) & _CONTOUR_CYCLES:
            continue
        first, last = line_of.get(int(p.value)), line_of.get(int(q.value))
        if first is not None and last is not None:
            for line in range(first, last + 1):
                inside.setdefault(line, block.line)
    return inside


# --------------------------------------------------------------------------------------------
# rewriting


@dataclass
class _Progress:
    """What one range has done so far (mutable: local to one rewrite)."""

    resolved: ResolvedRange
    feed_set: bool = False
    speed_set: bool = False
    rpm_needed: float | None = None  # spindle speed the new S gives at the operation's diameter


@dataclass
class _Pass:
    """The accumulators of one rewrite (mutable: local to :func:`rewrite_program`)."""

    program: str
    setpoints: Mapping[str, OperationSetpoint]
    changes: list[Change] = field(default_factory=list)
    warnings: list[Notice] = field(default_factory=list)
    edits: dict[int, list[tuple[int, int, str]]] = field(default_factory=dict)
    pending_feed: _Progress | None = None
    pending_speed: _Progress | None = None

    def warn(self, line: int | None, operation: str, message: str) -> None:
        self.warnings.append(Notice(line, operation, message))

    def where(self, block: Block) -> str:
        return f"{self.program} line {block.line}"


def rewrite_program(
    text: str,
    setpoints: Mapping[str, OperationSetpoint],
    ranges: Sequence[BlockRange],
    *,
    program_name: str = "program",
) -> RewriteResult:
    """Rewrite the F and S words of each operation's block range with its setpoint.

    Parameters
    ----------
    text : str
        The program (lines ending in LF or CRLF; both kept).
    setpoints : Mapping[str, OperationSetpoint]
        The setpoint of every operation named in ``ranges``.
    ranges : Sequence[BlockRange]
        The block ranges; an operation may have several, no two may share a line.
    program_name : str
        Name of the program in error messages (``"<name> line <n>"``).

    Returns
    -------
    RewriteResult
        The new text, the changes and the warnings (see the module docstring).

    Raises
    ------
    GcodeError
        When the program or a range cannot be rewritten safely (see the module docstring).

    Notes
    -----
    Under G95 an F word becomes ``f`` [mm/rev]; under G94 ``f · n`` [mm/min] with
    ``n = 1000 v / (π D)`` [rpm] at the operation's diameter D. Under G96 an S word becomes
    ``v`` [m/min]; under G97 ``n`` [rpm]. Values are rounded down (module docstring).
    """
    for r in ranges:
        if r.operation not in setpoints:
            raise GcodeError("map", r.describe(), f"no setpoint for operation {r.operation!r}")
    blocks = parse_program(text)
    located = resolve_ranges(blocks, ranges)
    last_line = located[-1].last_line
    for block in blocks[:last_line]:
        if block.problem:
            raise GcodeError(
                f"{program_name} line {block.line}",
                block.text.strip(),
                f"cannot be read: {block.problem}; every line up to the end of the last range "
                "must be plain G-code, so that its modes and flow are certain",
            )
    progress_at: dict[int, _Progress] = {}
    for resolved in located:
        tracker = _Progress(resolved)
        for number in range(resolved.first_line, resolved.last_line + 1):
            progress_at[number] = tracker
    contour = _contours(blocks)
    run = _Pass(program_name, setpoints)
    state = _unknown("no {names} before it", 0)
    for block in blocks:
        if block.problem:
            break  # after the last range: nothing more to rewrite or to warn about
        state = _enter(state, block)
        _carry_over(run, state, block)
        progress = progress_at.get(block.line)
        if progress is not None:
            _rewrite_block(run, state, block, progress, contour.get(block.line))
            if block.line == progress.resolved.last_line:
                _close(run, state, progress)
        state = _leave(state, block)
    out = []
    for block in blocks:
        written = block.text
        for start, end, new in sorted(run.edits.get(block.line, []), reverse=True):
            written = written[:start] + new + written[end:]
        out.append(written + block.ending)
    return RewriteResult(
        text="".join(out),
        changes=tuple(run.changes),
        warnings=tuple(sorted(run.warnings, key=lambda w: w.line or 0)),
        ranges=located,
        setpoints={r.operation: setpoints[r.operation] for r in ranges},
    )


def _rewrite_block(
    run: _Pass, state: _State, block: Block, progress: _Progress, contour_of: int | None
) -> None:
    op = run.setpoints[progress.resolved.range.operation]
    g = set(block.codes("G"))
    call = next((w for w in block.words if (w.letter, w.value) in _CALLS), None)
    if call is not None:
        run.warn(
            block.line,
            op.name,
            f"{_text(block, call)} calls a subprogram or macro: its F and S words are not "
            "rewritten, and the modes after it are not known",
        )
    feed, speed = block.word("F"), block.word("S")
    if speed is not None and g & _CLAMP_CODES:
        speed = None  # the spindle clamp, not a speed
    for word in (feed, speed):
        if word is not None and contour_of is not None:
            run.warn(
                block.line,
                op.name,
                f"{_text(block, word)} is in the contour of the cycle at line {contour_of} "
                "(P to Q): it applies to the G70 finishing pass; left unchanged",
            )
    if contour_of is not None:
        feed = speed = None
    if feed is not None:
        _rewrite_feed(run, state, block, feed, progress, op)
    if speed is not None:
        _rewrite_speed(run, state, block, speed, progress, op)
    if progress.rpm_needed is not None:
        _check_clamps(run, state, block, progress, op)


def _metric(run: _Pass, state: _State, block: Block, word: Word) -> None:
    if state.units.code == "G20":
        raise GcodeError(
            run.where(block),
            _text(block, word),
            f"the program is in inches (G20 at line {state.units.line}); the setpoints are "
            "metric and rcb gcode rewrites millimetre (G21) programs only",
        )
    if state.units.code is None:
        raise GcodeError(
            run.where(block),
            _text(block, word),
            f"the unit mode is not known ({state.units.why}); add G21 (millimetres) before it",
        )


def _rewrite_feed(
    run: _Pass, state: _State, block: Block, word: Word, progress: _Progress, op: OperationSetpoint
) -> None:
    g = set(block.codes("G"))
    old = _text(block, word)
    threading = Decimal(76) in g or state.motion == "thread"  # _enter set it from the block
    if threading or state.cycle == "tap":
        what = "the thread lead" if threading else "the tapping pitch feed"
        run.warn(block.line, op.name, f"{old} is {what}; left unchanged")
        return
    _metric(run, state, block, word)
    mode = state.feed.code
    if mode is None:
        raise GcodeError(run.where(block), old, f"the feed mode is not known ({state.feed.why})")
    if mode == "G93":
        raise GcodeError(
            run.where(block),
            old,
            f"inverse-time feed (G93 at line {state.feed.line}) cannot carry a feed per "
            "revolution; use G94 or G95",
        )
    if mode == "G95":
        value = _floor(op.feed_mm_rev, FEED_MM_REV_PLACES)
        new = _styled(value, word.number, FEED_MM_REV_PLACES, point=True)
        quantity: Quantity = "feed_mm_rev"
    else:
        value = _floor(op.feed_mm_rev * op.spindle_rpm, FEED_MM_MIN_PLACES)
        new = _styled(value, word.number, FEED_MM_MIN_PLACES, point=False)
        quantity = "feed_rate_mm_min"
        if state.spindle.code == "G96":
            run.warn(
                block.line,
                op.name,
                f"{old} is a feed per minute (G94) under constant surface speed (G96): the "
                f"feed per revolution is {op.feed_mm_rev:.4g} mm/rev only at "
                f"Ø{op.workpiece_diameter_mm:g} mm",
            )
    if value <= 0:
        raise GcodeError(run.where(block), old, f"the new feed rounds to {value} ({mode})")
    _edit(run, block, word, new, op, quantity, mode)
    progress.feed_set = True
    run.pending_feed = progress


def _rewrite_speed(
    run: _Pass, state: _State, block: Block, word: Word, progress: _Progress, op: OperationSetpoint
) -> None:
    old = _text(block, word)
    _metric(run, state, block, word)
    mode = state.spindle.code
    if mode is None:
        raise GcodeError(
            run.where(block), old, f"the spindle mode is not known ({state.spindle.why})"
        )
    if mode == "G96":
        value = _floor(op.speed_m_min, SPEED_PLACES)
        rpm = turning_spindle_rpm(float(value), op.workpiece_diameter_mm)
        quantity: Quantity = "speed_m_min"
    else:
        value = _floor(op.spindle_rpm, SPEED_PLACES)
        rpm = float(value)
        quantity = "spindle_rpm"
    if value <= 0:
        raise GcodeError(run.where(block), old, f"the new speed rounds to {value} ({mode})")
    _edit(
        run, block, word, _styled(value, word.number, SPEED_PLACES, point=False), op, quantity, mode
    )
    progress.speed_set = True
    progress.rpm_needed = rpm
    run.pending_speed = progress


def _check_clamps(
    run: _Pass, state: _State, block: Block, progress: _Progress, op: OperationSetpoint
) -> None:
    rpm = progress.rpm_needed
    assert rpm is not None
    for clamp in state.clamps:
        if clamp.rpm < rpm * (1 - 1e-9):
            raise GcodeError(
                run.where(block),
                block.text.strip(),
                f"the spindle clamp {clamp.word} (line {clamp.line}) is below the "
                f"{rpm:.1f} rpm that {op.speed_m_min:.4g} m/min needs at "
                f"Ø{op.workpiece_diameter_mm:g} mm for operation {op.name!r}: the control "
                "would cut slower than the setpoint; raise the clamp, or give the plan's "
                "machine max_spindle_rpm",
            )


def _edit(
    run: _Pass,
    block: Block,
    word: Word,
    number: str,
    op: OperationSetpoint,
    quantity: Quantity,
    mode: str,
) -> None:
    run.edits.setdefault(block.line, []).append((word.number_start, word.end, number))
    old = _text(block, word)
    new = block.text[word.start : word.number_start] + number
    run.changes.append(Change(block.line, word.start + 1, op.name, old, new, quantity, mode))


def _close(run: _Pass, state: _State, progress: _Progress) -> None:
    """Warn about a range with no F or no S word."""
    r = progress.resolved
    where = f"N{r.range.start}-N{r.range.end} (lines {r.first_line}-{r.last_line})"
    for done, letter, last in (
        (progress.feed_set, "F", state.last_feed),
        (progress.speed_set, "S", state.last_speed),
    ):
        if done:
            continue
        before = f"{last[1]} from line {last[0]} stays in force" if last else f"no {letter} is set"
        run.warn(
            r.first_line,
            r.range.operation,
            f"no {letter} word to rewrite in {where}: {before}; add one to the range to carry "
            "the setpoint",
        )


def _carry_over(run: _Pass, state: _State, block: Block) -> None:
    """Warn when a new F or S of a range stays in force for a cutting move after the range."""
    g = set(block.codes("G"))
    ends = any((w.letter, w.value) in _ENDS | _CALLS for w in block.words)
    ends = ends or block.marker or block.word("O") is not None
    cuts = bool(g & _CYCLE_CUTS) or (
        state.motion == "cut" and any(w.letter in _AXES for w in block.words)
    )
    speed = block.word("S") is not None and not g & _CLAMP_CODES
    stop = ("M", Decimal(5)) in {(w.letter, w.value) for w in block.words}
    for kind, pending, replaced in (
        ("F", run.pending_feed, block.word("F") is not None),
        ("S", run.pending_speed, speed or stop),
    ):
        if pending is None or block.line <= pending.resolved.last_line:
            continue
        if cuts and not replaced:
            r = pending.resolved
            run.warn(
                block.line,
                r.range.operation,
                f"the new {kind} of N{r.range.start}-N{r.range.end} is still in force for "
                f"the cutting move at line {block.line}, after the range",
            )
        if cuts or replaced or ends:
            if kind == "F":
                run.pending_feed = None
            else:
                run.pending_speed = None


# --------------------------------------------------------------------------------------------
# numbers


def _floor(value: float, places: int) -> Decimal:
    """``value`` rounded down to ``places`` decimals, after float noise is removed.

    ``199.99999999999991`` (an optimum on a bound) is 200, not 199: the value is first
    rounded to 12 significant digits.
    """
    exact = Decimal(f"{value:.12g}")  # finite: OperationSetpoint checks it
    return exact.quantize(Decimal(1).scaleb(-places), rounding=ROUND_FLOOR)


def _styled(value: Decimal, original: str, places: int, *, point: bool) -> str:
    """``value`` written in the style of the number ``original`` (module docstring)."""
    sign = "+" if original.startswith("+") else ""
    body = original.lstrip("+-")
    integer, had_point, decimals = body.partition(".")
    whole, _, fraction = f"{value:.{places}f}".partition(".")
    fraction = fraction.rstrip("0").ljust(len(decimals), "0")
    if fraction:
        text = f"{whole}.{fraction}"
    elif had_point or point:
        text = f"{whole}."
    else:
        text = whole
    if not integer and whole == "0" and "." in text:
        text = text[1:]  # the original had no leading zero: ".25" → ".325"
    return sign + text
