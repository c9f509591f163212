"""Modal state along a program: units, feed and spindle modes, G50 clamps, motion, dialect rules."""

from __future__ import annotations

from dataclasses import dataclass
from decimal import Decimal

from supervisor.gcode.lexer import Block, _text

_AXES = frozenset("XYZUVWABC")


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

    @property
    def last(self) -> tuple[tuple[int, str] | None, tuple[int, str] | None]:
        """``last_feed`` and ``last_speed``."""
        return self.last_feed, self.last_speed


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
#: The letters of the words :func:`_leave` reads: a block with none leaves the state as it is.
_LEAVING = frozenset("MGOFS")
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
    if not g:
        return state  # every mode, the motion, the cycle and the clamps are set by G codes
    if g <= _MOTION.keys():  # G00-G03 alone: the motion, and no canned cycle
        motion = _MOTION[max(g)]
        if (state.motion, state.cycle) == (motion, ""):
            return state
        return _State(state.units, state.feed, state.spindle, state.clamps, motion, "", *state.last)
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
        clamp = _Clamp(float(speed.value), n, _text(block, speed))
        clamps = _added(clamps, clamp) if block.optional_skip else (clamp,)
    units, feed, spindle = modes["units"], modes["feed"], modes["spindle"]
    return _State(units, feed, spindle, clamps, motion, cycle, *state.last)


def _leave(state: _State, block: Block) -> _State:
    """The state after ``block``: subprogram calls and program ends make every mode unknown."""
    if not any(w.letter in _LEAVING for w in block.words):
        return state
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
    a = after
    return _State(a.units, a.feed, a.spindle, a.clamps, a.motion, a.cycle, last_feed, last_speed)


def _added(clamps: tuple[_Clamp, ...], clamp: _Clamp) -> tuple[_Clamp, ...]:
    """The clamps that may be in force once ``clamp`` may be too (an optional-skip block).

    A clamp no lower than one before it is dropped: a setpoint it would refuse, the earlier
    one refuses first (:func:`supervisor.gcode.rewrite._check_clamps` names the first). So
    the tuple stays short however many optional-skip clamps a program has.
    """
    if any(before.rpm <= clamp.rpm for before in clamps):
        return clamps
    return (*clamps, clamp)
