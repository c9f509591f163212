"""The result of a rewrite: the new text, the rewritten words and the warnings."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from supervisor.gcode.numbers import Quantity
from supervisor.gcode.ranges import OperationSetpoint, ResolvedRange


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
