"""The rewrite: each operation's F and S words in its block range get its setpoint."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from decimal import Decimal

from models.kinematics import turning_spindle_rpm
from supervisor.gcode.errors import GcodeError
from supervisor.gcode.lexer import Block, Word, _text, parse_program
from supervisor.gcode.modes import (
    _AXES,
    _CALLS,
    _CLAMP_CODES,
    _CYCLE_CUTS,
    _ENDS,
    _contours,
    _enter,
    _leave,
    _State,
    _unknown,
)
from supervisor.gcode.numbers import (
    FEED_MM_MIN_PLACES,
    FEED_MM_REV_PLACES,
    SPEED_PLACES,
    Quantity,
    _floor,
    _styled,
)
from supervisor.gcode.ranges import BlockRange, OperationSetpoint, ResolvedRange, resolve_ranges
from supervisor.gcode.result import Change, Notice, RewriteResult


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
        The new text, the changes and the warnings (see the package docstring).

    Raises
    ------
    GcodeError
        When the program or a range cannot be rewritten safely (see the package docstring).

    Notes
    -----
    Under G95 an F word becomes ``f`` [mm/rev]; under G94 ``f · n`` [mm/min] with
    ``n = 1000 v / (π D)`` [rpm] at the operation's diameter D. Under G96 an S word becomes
    ``v`` [m/min]; under G97 ``n`` [rpm]. Values are rounded down (package docstring).
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
