"""The result of a rewrite: what changed and the warnings, counted in full, listed up to a cap."""

from __future__ import annotations

import bisect
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Generic, TypeVar

from supervisor.gcode.numbers import Quantity
from supervisor.gcode.ranges import OperationSetpoint, ResolvedRange

#: The most changes, and the most warnings, a rewrite lists (the first in program order); every
#: one is counted. A 50 MB program changes about a million words: the program itself is the
#: full record, and a result (``rcb gcode --json``) stays a few hundred kB whatever its size.
MAX_LISTED = 1000

_T = TypeVar("_T")


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


@dataclass(frozen=True, kw_only=True)
class RewriteReport:
    """What a rewrite changed and the warnings (the program itself was written elsewhere).

    Parameters
    ----------
    changes : tuple[Change, ...]
        The first :data:`MAX_LISTED` (or the cap given) rewritten words, in program order.
    warnings : tuple[Notice, ...]
        The first warnings, in program order, as many at most.
    ranges : tuple[ResolvedRange, ...]
        The ranges, in program order.
    setpoints : Mapping[str, OperationSetpoint]
        The setpoints written, by operation.
    change_count : int
        Every rewritten word, listed or not.
    warning_count : int
        Every warning, listed or not.
    changes_by_operation : Mapping[str, int]
        Every rewritten word, counted by operation (operations with none included).
    """

    changes: tuple[Change, ...]
    warnings: tuple[Notice, ...]
    ranges: tuple[ResolvedRange, ...]
    setpoints: Mapping[str, OperationSetpoint]
    change_count: int
    warning_count: int
    changes_by_operation: Mapping[str, int]


@dataclass(frozen=True, kw_only=True)
class RewriteResult(RewriteReport):
    """A :class:`RewriteReport` with the rewritten program (:func:`rewrite_program`).

    Parameters
    ----------
    text : str
        The new program: the input with only the F and S numbers of the changes replaced.
    """

    text: str


@dataclass
class Listing(Generic[_T]):
    """The first ``cap`` items by key (ties in the order added), and how many were added.

    Mutable, local to one rewrite: items mostly come in key order, so adding is cheap.
    """

    cap: int | None
    count: int = 0
    _keys: list[tuple[int, int]] = field(default_factory=list)
    _items: list[_T] = field(default_factory=list)

    def add(self, key: int, item: _T) -> None:
        """Count ``item``; keep it if it is among the first ``cap`` by ``key``."""
        order = (key, self.count)
        self.count += 1
        if self.cap is not None and len(self._keys) >= self.cap:
            if not self._keys or order >= self._keys[-1]:
                return
        at = bisect.bisect_right(self._keys, order)
        self._keys.insert(at, order)
        self._items.insert(at, item)
        if self.cap is not None and len(self._keys) > self.cap:
            self._keys.pop()
            self._items.pop()

    def listed(self) -> tuple[_T, ...]:
        """The items kept, by key."""
        return tuple(self._items)
