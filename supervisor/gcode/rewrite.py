"""The rewrite of one block: its F and S words get its operation's setpoint, or a warning.

:func:`supervisor.gcode.stream.rewrite_stream` walks the program a block at a time and calls
:func:`rewrite_block` for each block inside a range, :func:`close_range` at a range's last
block and :func:`carry_over` for every block; they record what they change and warn about in a
:class:`Pass`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from decimal import Decimal

from models.kinematics import turning_spindle_rpm
from supervisor.gcode.errors import GcodeError
from supervisor.gcode.lexer import Block, Word, _text
from supervisor.gcode.modes import _AXES, _CALLS, _CLAMP_CODES, _CYCLE_CUTS, _ENDS, _State
from supervisor.gcode.numbers import (
    FEED_MM_MIN_PLACES,
    FEED_MM_REV_PLACES,
    SPEED_PLACES,
    Quantity,
    _floor,
    _styled,
)
from supervisor.gcode.ranges import OperationSetpoint, ResolvedRange
from supervisor.gcode.result import Change, Listing, Notice


@dataclass
class Progress:
    """What one range has done so far (mutable: local to one rewrite)."""

    resolved: ResolvedRange
    feed_set: bool = False
    speed_set: bool = False
    rpm_needed: float | None = None  # spindle speed the new S gives at the operation's diameter


@dataclass
class Pass:
    """The accumulators of one rewrite (mutable: local to one rewrite).

    ``changes`` and ``warnings`` count everything and keep the first ``listed`` of each;
    ``edits`` are those of the block being rewritten (start, end, new number), taken with
    :meth:`take_edits` once it is done.
    """

    program: str
    setpoints: Mapping[str, OperationSetpoint]
    changes: Listing[Change]
    warnings: Listing[Notice]
    by_operation: dict[str, int] = field(default_factory=dict)
    edits: list[tuple[int, int, str]] = field(default_factory=list)
    pending_feed: Progress | None = None
    pending_speed: Progress | None = None

    def warn(self, line: int | None, operation: str, message: str) -> None:
        """Record a warning about ``line``."""
        self.warnings.add(line or 0, Notice(line, operation, message))

    def where(self, block: Block) -> str:
        """The field of an error about ``block``: ``"<program> line <n>"``."""
        return f"{self.program} line {block.line}"

    def take_edits(self) -> list[tuple[int, int, str]]:
        """The edits of the block just rewritten; none are left."""
        edits, self.edits = self.edits, []
        return edits


def rewrite_block(
    run: Pass, state: _State, block: Block, progress: Progress, contour_of: int | None
) -> None:
    """Rewrite the F and S words of ``block``, inside ``progress``'s range, or warn."""
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


def _metric(run: Pass, state: _State, block: Block, word: Word) -> None:
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
    run: Pass, state: _State, block: Block, word: Word, progress: Progress, op: OperationSetpoint
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
    run: Pass, state: _State, block: Block, word: Word, progress: Progress, op: OperationSetpoint
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
    run: Pass, state: _State, block: Block, progress: Progress, op: OperationSetpoint
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
    run: Pass,
    block: Block,
    word: Word,
    number: str,
    op: OperationSetpoint,
    quantity: Quantity,
    mode: str,
) -> None:
    old = block.text[word.start : word.end]  # whole: a change says exactly what it replaced
    new = block.text[word.start : word.number_start] + number
    if new == old:  # the setpoint's number as written already: nothing to change or count
        return
    run.edits.append((word.number_start, word.end, number))
    change = Change(block.line, word.start + 1, op.name, old, new, quantity, mode)
    run.changes.add(block.line, change)
    run.by_operation[op.name] = run.by_operation.get(op.name, 0) + 1


def close_range(run: Pass, state: _State, progress: Progress) -> None:
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


def carry_over(run: Pass, state: _State, block: Block) -> None:
    """Warn when a new F or S of a range stays in force for a cutting move after the range."""
    if all(
        pending is None or block.line <= pending.resolved.last_line
        for pending in (run.pending_feed, run.pending_speed)
    ):
        return  # no new F or S, or still in its range
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
