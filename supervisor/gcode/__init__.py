"""Rewrite the feed (F) and spindle speed (S) words of a lathe program with the setpoints.

Modules: :mod:`~supervisor.gcode.source` (a program's lines from a binary stream, bounded),
:mod:`~supervisor.gcode.lexer` (reading lines, words and comments),
:mod:`~supervisor.gcode.modes` (the modal state along a program),
:mod:`~supervisor.gcode.ranges` (each operation's setpoint and block range),
:mod:`~supervisor.gcode.contours` (the contour blocks of G70-G73 cycles),
:mod:`~supervisor.gcode.scan` (the readings before the rewrite),
:mod:`~supervisor.gcode.numbers` (the new F and S numbers and their style),
:mod:`~supervisor.gcode.rewrite` (the rewrite of a block), :mod:`~supervisor.gcode.stream`
(the rewrite of a program, streamed), :mod:`~supervisor.gcode.result` (its result)
and :mod:`~supervisor.gcode.errors` (:class:`GcodeError`). The public names are re-exported
here.

Size. :func:`rewrite_stream` reads the program from a binary stream a line at a time and
writes the new one as it goes: its memory does not grow with the program and its time grows
linearly (:func:`rewrite_program` does the same on a text in memory). A line longer than
:data:`MAX_LINE_BYTES` (4096) is refused after that many bytes are read. Every change and
warning is counted; the first :data:`MAX_LISTED` (1000) of each are listed.

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
  ranges;
- a line longer than :data:`MAX_LINE_BYTES`, anywhere in the program, and a program that
  changed between two readings.

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

from supervisor.gcode.errors import GcodeError
from supervisor.gcode.lexer import Block, Word, parse_program
from supervisor.gcode.numbers import (
    FEED_MM_MIN_PLACES,
    FEED_MM_REV_PLACES,
    SPEED_PLACES,
    Quantity,
)
from supervisor.gcode.ranges import (
    BlockRange,
    OperationSetpoint,
    ResolvedRange,
    parse_range,
    resolve_ranges,
)
from supervisor.gcode.result import MAX_LISTED, Change, Notice, RewriteReport, RewriteResult
from supervisor.gcode.source import MAX_LINE_BYTES
from supervisor.gcode.stream import rewrite_program, rewrite_stream

__all__ = [
    "FEED_MM_MIN_PLACES",
    "FEED_MM_REV_PLACES",
    "MAX_LINE_BYTES",
    "MAX_LISTED",
    "SPEED_PLACES",
    "Block",
    "BlockRange",
    "Change",
    "GcodeError",
    "Notice",
    "OperationSetpoint",
    "Quantity",
    "ResolvedRange",
    "RewriteReport",
    "RewriteResult",
    "Word",
    "parse_program",
    "parse_range",
    "resolve_ranges",
    "rewrite_program",
    "rewrite_stream",
]
