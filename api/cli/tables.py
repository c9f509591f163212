r"""Rich tables of the CLI: their common look and width rule, predictions, a plan's setpoints.

Every table of every command is made by :func:`new_table` and fits the console (80 columns in
a pipe, a log or a default terminal): cells wrap between words and a word wider than its
column is folded onto the next line, never cut with an ellipsis, so no number is ever lost. A
word holding a digit (``0.3557``, ``feed=0.3557``, a serial) is the last to be folded: only
where the numbers alone are wider than the console.

A cell shows its text, never acts on the terminal: a control or invisible format character in
it (an ESC of stored text, a zero-width space) is shown escaped, ``\x1b`` (:func:`shown_text`).
"""

from __future__ import annotations

import re
import unicodedata
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from rich import box
from rich.cells import cell_len
from rich.console import Console, ConsoleOptions, RenderableType, RenderResult
from rich.measure import Measurement
from rich.table import Column, Table
from rich.text import Text

from models.powerlaw import Prediction
from models.quantities import DERIVED_QUANTITIES, MODEL_QUANTITIES

if TYPE_CHECKING:  # only in signatures: the tables load no NumPy (rcb --help imports them)
    from supervisor.optimize.result import OperationResult, PlanResult

#: A word holding a digit: a number, ``name=value``, a date, a serial (never folded).
_DIGIT = re.compile(r"[0-9]")
#: A number word of free text: ``1796389920.0,``, ``-3.5e-4``, ``127.0.0.1``, ``2026-12-04``,
#: ``60%`` (never folded there); not ``v1`` nor ``operations[0].bounds`` (a name, a path).
_NUMBER = re.compile(r"[(\[]?[-+±]?\.?[0-9][0-9.,:eE+\-]*%?[)\],;:]*")
#: The widest word holding a digit kept whole as a number (a serial, ``lathe-22kW``) unless
#: it is one (:data:`_NUMBER`) or ``name=number``: a longer one is a name
#: (``milling-demo-part-for-the-customer-acme-lot-07``) and folds as words do.
DIGIT_KEPT = 20
_PAIR = re.compile(r"[^=\s]+=" + _NUMBER.pattern)

_UNITS = {q.name: q.unit for q in (*MODEL_QUANTITIES.values(), *DERIVED_QUANTITIES.values())}


#: Short column headings of the cutting parameters.
PARAMETER_HEADINGS = {
    "depth_mm": "d\nmm",
    "feed_mm_rev": "f\nmm/rev",
    "axial_depth_mm": "ap\nmm",
    "radial_depth_mm": "ae\nmm",
    "feed_per_tooth_mm": "fz\nmm",
    "speed_m_min": "v\nm/min",
}


#: Characters a cell shows escaped: controls (but a line break), invisible format characters,
#: surrogates, line and paragraph separators (as :func:`models.fields.identity` refuses).
_ESCAPED = frozenset(("Cc", "Cf", "Cs", "Zl", "Zp"))


def _escape(char: str) -> str:
    code = ord(char)
    return (
        f"\\x{code:02x}"
        if code < 0x100
        else f"\\u{code:04x}"
        if code < 0x10000
        else f"\\U{code:08x}"
    )


def shown_text(text: str, limit: int | None = None) -> str:
    r"""``text`` as a terminal may show it: control and format characters escaped (``\x1b``).

    A line break is kept. ``limit``: at most that many characters, cut with ``…``.
    """
    if not all(line.isprintable() for line in text.split("\n")):  # fast: most text is
        text = "".join(
            _escape(c) if c != "\n" and unicodedata.category(c) in _ESCAPED else c for c in text
        )
    if limit is not None and len(text) > limit:
        text = text[: limit - 1] + "…"
    return text


def _shown_cell(cell: Any) -> Any:
    """A cell with its text shown safely (:func:`shown_text`); a Text keeps its style."""
    if isinstance(cell, str):
        return shown_text(cell)
    if isinstance(cell, Text):
        plain = cell.plain
        safe = shown_text(plain)
        return cell if safe == plain else Text(safe, style=cell.style)
    return cell


class _FoldingTable(Table):
    """A table whose every column wraps between words and folds a longer word: never cut.

    rich cuts a cell (``0.55…``) in a column that may not wrap or whose overflow is
    ``ellipsis`` (its default); here a narrow console costs lines, not digits.
    """

    def add_column(self, *args: Any, **kwargs: Any) -> None:
        """As :meth:`rich.table.Table.add_column`, with ``no_wrap`` off and ``overflow="fold"``."""
        super().add_column(*args, **{**kwargs, "no_wrap": False, "overflow": "fold"})

    def add_row(self, *renderables: Any, **kwargs: Any) -> None:
        """As :meth:`rich.table.Table.add_row`, each text cell shown safely (:func:`shown_text`)."""
        super().add_row(*(_shown_cell(cell) for cell in renderables), **kwargs)

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> RenderResult:
        """Rendered with :func:`_shared_widths` when too wide (rich alone folds the widest)."""
        widths = _shared_widths(self, console, options)
        saved = [column.width for column in self.columns]
        if widths is not None:
            for column, width in zip(self.columns, widths, strict=True):
                column.width = width
        try:
            yield from super().__rich_console__(console, options)
        finally:
            for column, before in zip(self.columns, saved, strict=True):
                column.width = before


def _shared_widths(table: Table, console: Console, options: ConsoleOptions) -> list[int] | None:
    """Column widths for a table wider than the console, or None (it fits, or cannot).

    Each column has five widths, each at least the one before (:func:`_levels`): its widest
    word holding a digit (a number, ``feed=0.3557``, a date, a serial: never folded), its
    heading's widest word, its ``min_width`` (a phrase kept on one line), its widest word, its
    natural width. Every column gets the widest level the console holds for all of them, and
    the rest of the width goes to the columns short of the next level, the widest cut first:
    a narrow console folds a long name (``roughness_um``) before a heading, and a heading
    before a number. Where the numbers alone are wider than the console, the widest columns
    are cut to one width first, their numbers folded (rich would keep each ``min_width`` and
    cut the table's right edge off).
    """
    if any(column.width is not None for column in table.columns):
        return None
    wide = options.update(max_width=10**6)
    levels = [_levels(console, wide, column) for column in table.columns]
    natural = sum(level[-1] for level in levels)
    room = options.max_width - (Measurement.get(console, wide, table).maximum - natural)
    if natural <= room or room < len(levels):
        return None
    if sum(level[0] for level in levels) > room:  # the numbers alone: the widest columns fold
        cap = max(c for c in range(1, room + 1) if sum(min(lv[-1], c) for lv in levels) <= room)
        levels = [tuple(min(width, cap) for width in level) for level in levels]
    totals = [sum(level[k] for level in levels) for k in range(len(levels[0]))]
    k = next((k for k, total in enumerate(totals) if total > room), None)
    if k is None:
        return [level[-1] for level in levels]
    widths = [level[k] for level in levels]
    while sum(widths) > room:  # one cell off the widest column still above its lower level
        cut = max(
            (i for i, level in enumerate(levels) if widths[i] > level[k - 1]),
            key=lambda i: (widths[i], i),
        )
        widths[cut] -= 1
    return widths


def free_text(column: Column, kept: int = 0) -> None:
    """Mark ``column`` as free text (an audit entry's detail, a name): its words fold first.

    A word holding a digit there is a message's word (``operations[0].bounds.feed_mm_rev``)
    or a name (``plan-7``), folded as any; only a number word (``1796389920.0,``, ``60.0``,
    ``127.0.0.1``: :data:`_NUMBER`) is kept whole, at the never-fold level. ``kept``: a width
    folded as late as the headings (an audit detail's longest key, ``window_start_s:``).
    """
    column.free_text = True  # type: ignore[attr-defined]  # rich's Column is a plain dataclass
    column.free_kept = kept  # type: ignore[attr-defined]


def _levels(console: Console, wide: ConsoleOptions, column: Column) -> tuple[int, ...]:
    """A column's widths: numbers whole, heading's words (and kept), min_width, words, natural."""
    cells = [Measurement.get(console, wide, c) for c in (column.header, *column.cells)]
    natural = max([column.min_width or 0, *(m.maximum for m in cells)])  # as rich measures it
    heading = _word_widths(console, wide, column.header, None)
    free = getattr(column, "free_text", False)  # its words fold first, but a number's
    body = [_word_widths(console, wide, c, _NUMBER if free else None) for c in column.cells]
    numbers = max([heading[0], *(b[0] for b in body)])
    head = max(numbers, heading[1], min(getattr(column, "free_kept", 0), natural))
    phrase = max(head, column.min_width or 0)
    words = max([phrase, *(m.minimum for m in cells)])
    return numbers, head, phrase, words, natural


def _word_widths(
    console: Console, wide: ConsoleOptions, cell: RenderableType, number: re.Pattern[str] | None
) -> tuple[int, int]:
    """The widest number word of a cell, and its widest word (0 if none).

    A number word: one holding a digit (a longer one than :data:`DIGIT_KEPT` only if a number
    or ``name=number``), or, given ``number``, one it matches whole.

    A cell that is not text (a nested table, a padding) is kept whole: both its minimum width.
    """
    if isinstance(cell, str):
        cell = console.render_str(cell)
    if not isinstance(cell, Text):
        least = Measurement.get(console, wide, cell).minimum
        return least, least
    words = cell.plain.split()
    kept = [w for w in words if _kept(w, number)]
    numbers = max((cell_len(w) for w in kept), default=0)
    return numbers, max((cell_len(w) for w in words), default=0)


def _kept(word: str, number: re.Pattern[str] | None) -> bool:
    """Whether ``word`` is kept whole as a number (``number``: what one is, else a digit)."""
    if number is not None:
        return number.fullmatch(word) is not None
    if not _DIGIT.search(word):
        return False
    return len(word) <= DIGIT_KEPT or bool(_NUMBER.fullmatch(word) or _PAIR.fullmatch(word))


def new_table(*headings: str, **options: Any) -> Table:
    """A CLI table: a rule under the headings, no frame, two spaces between columns.

    ``headings`` and ``options`` (``title``, ``caption`` ...) as :class:`rich.table.Table`'s.
    A title wraps at the table's width: the table is at least as wide as the title's longest
    word (a plan's name, up to the console's width), which was folded mid-word above a narrow
    table (``...-lot-07-seco`` / ``nd-op``).
    """
    title = options.get("title")
    if isinstance(title, str) and title.split() and "min_width" not in options:
        options["min_width"] = max(cell_len(word) for word in title.split())
    style: dict[str, Any] = {
        "box": box.SIMPLE_HEAD,
        "show_edge": False,
        "pad_edge": False,
        "collapse_padding": True,
        **options,
    }
    return _FoldingTable(*headings, **style)


def fmt(value: float) -> str:
    """A number as the CLI tables print it."""
    return f"{value:.4g}" if abs(value) < 1e5 else f"{value:.3e}"


def predictions_table(title: str, predicted: Mapping[str, Prediction]) -> Table:
    """Quantity, unit, value, band, and the band edges."""
    table = new_table(title=title)
    for column in ("quantity", "unit", "value", "± band", "lower", "upper"):
        table.add_column(column, justify="left" if column in ("quantity", "unit") else "right")
    for name, p in predicted.items():
        table.add_row(
            name, _UNITS.get(name, ""), fmt(p.value), fmt(p.band), fmt(p.lower), fmt(p.upper)
        )
    return table


def plan_table(result: PlanResult) -> Table:
    """One row per operation: each cutting parameter, MRR, time, binding constraints.

    Fits 80 columns for a turning plan; the tool is in each operation's own table.
    """
    table = new_table(title=f"plan {result.plan} on {result.machine}: robust optimum")
    params = [p for p in PARAMETER_HEADINGS if any(p in op.setpoint for op in result.operations)]
    table.add_column("operation", overflow="fold", min_width=9)
    for p in params:
        table.add_column(PARAMETER_HEADINGS[p], justify="right")
    table.add_column("MRR\ncm³/min", justify="right")
    table.add_column("time\nmin", justify="right")
    table.add_column("binding")
    for op in result.operations:
        values = [fmt(op.setpoint[p]) if p in op.setpoint else "" for p in params]
        table.add_row(
            op.name, *values, fmt(op.mrr_cm3_min), fmt(op.time_min), "\n".join(op.binding)
        )
    table.caption = f"cycle time {result.cycle_time_min:.4g} min"
    return table


def setpoint_caption(op: OperationResult) -> str | None:
    """Productivity cost and constant-load limits of a setpoint, where it has them.

    The constant load takes two lines, each a whole phrase. Printed under the table, not as
    its caption: a caption wraps at the table's width (58 cells for an end-mill), which split
    "(upper set / by the setpoint)".
    """
    lines = []
    if op.objective != "mrr" or op.cost_per_kg is not None:
        lines.append(f"objective {op.objective}; J = {fmt(op.cost_per_kg or 0.0)} /kg")
    c = op.constant_load
    if c is not None:
        lines.append(
            f"constant load: {fmt(c.reference_current_A)} A, feed "
            f"{fmt(c.feed_rate_lower_mm_min)}-{fmt(c.feed_rate_upper_mm_min)} mm/min"
        )
        lines.append(
            f"(upper set by the {c.upper_governed_by}); change tool at the lower limit"
            + ("" if c.tool_change_by_feed else ": not by feed here, by count")
        )
    return "\n".join(lines) or None


def short_number(value: float | None) -> str:
    """A number for a table cell: 4 significant digits, ``-`` for none (never cut: one word)."""
    if value is None:
        return "-"
    return f"{value:.4g}" if abs(value) < 1e5 else f"{value:.3e}"
