"""Which operation a block or a tool belongs to: ``OP=N100:N200`` or ``OP=T3``.

Block ranges are read by :func:`supervisor.gcode.parse_range`, the parser of ``rcb gcode --map``,
so one map serves both commands. A streamed block belongs to an operation when its number ``N``
lies in the range, ends included; a block without a number keeps the operation of the block
before it (the program's unnumbered lines between ``N100`` and ``N200`` belong to the range).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

from models.errors import InputError
from supervisor.gcode import GcodeError, parse_range

_TOOL = re.compile(r"\s*[Tt](\d+)\s*")
#: A block's number: an optional block-skip ``/``, then ``N`` and digits at the block's start.
_BLOCK_NUMBER = re.compile(r"\s*/?\s*[Nn](\d+)")


@dataclass(frozen=True)
class OperationSelector:
    """One operation and the blocks (``first_block..last_block``) or the tool that select it."""

    operation: str
    first_block: int | None = None
    last_block: int | None = None
    tool_number: int | None = None

    def describe(self) -> str:
        """``rough-od=N100:N200`` or ``rough-od=T1``."""
        if self.tool_number is not None:
            return f"{self.operation}=T{self.tool_number}"
        return f"{self.operation}=N{self.first_block}:N{self.last_block}"


def parse_selector(text: str, field: str = "operations") -> OperationSelector:
    """Read ``OP=N100:N200`` (the ``rcb gcode --map`` form) or ``OP=T3``.

    Raises
    ------
    InputError
        Naming ``field`` and the text when it is neither form or the range ends before it starts.
    """
    name, sep, rest = text.rpartition("=")
    tool = _TOOL.fullmatch(rest)
    if sep and name.strip() and tool is not None:
        return OperationSelector(name.strip(), tool_number=int(tool.group(1)))
    try:
        found = parse_range(text)
    except GcodeError:
        why = "must be OPERATION=N<start>:N<end> (as rcb gcode --map) or OPERATION=T<tool>"
        raise InputError(field, text, why) from None
    if found.end < found.start:
        raise InputError(field, text, f"block N{found.end} is before block N{found.start}")
    return OperationSelector(found.operation, found.start, found.end)


def check_selectors(selectors: Sequence[OperationSelector], field: str = "operations") -> None:
    """Refuse overlapping ranges, a tool given twice, an operation given twice, or both kinds."""
    if not selectors:
        raise InputError(field, [], "give at least one OPERATION=N<start>:N<end> or OPERATION=T<n>")
    names = [s.operation for s in selectors]
    for name in names:
        if names.count(name) > 1:
            raise InputError(field, name, "operation given twice")
    by_tool = [s for s in selectors if s.tool_number is not None]
    if by_tool and len(by_tool) != len(selectors):
        raise InputError(field, [s.describe() for s in selectors], "mix of block ranges and tools")
    tools = [s.tool_number for s in by_tool]
    for s in by_tool:
        if tools.count(s.tool_number) > 1:
            raise InputError(field, s.describe(), "tool selects two operations")
    ranges = sorted((s for s in selectors if s.first_block is not None), key=_start)
    for before, after in zip(ranges, ranges[1:], strict=False):
        if _start(after) <= (before.last_block or 0):
            raise InputError(field, after.describe(), f"overlaps {before.describe()}")


def _start(selector: OperationSelector) -> int:
    return selector.first_block or 0


def block_number(text: str | None) -> int | None:
    """The ``N`` number at the start of a block's text (``"N120 G01 Z-110."`` → 120), or None."""
    if text is None:
        return None
    found = _BLOCK_NUMBER.match(text)
    return int(found.group(1)) if found else None


def operation_at(
    selectors: Sequence[OperationSelector], block: int | None, tool: int | None
) -> str | None:
    """The operation a block number or a tool number selects (None: no mapped operation)."""
    for s in selectors:
        if s.tool_number is not None:
            if tool == s.tool_number:
                return s.operation
        elif block is not None and (s.first_block or 0) <= block <= (s.last_block or 0):
            return s.operation
    return None
