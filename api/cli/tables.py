"""Rich tables of the CLI: their common look and width rule, predictions, a plan's setpoints.

Every table of every command is made by :func:`new_table` and fits the console (80 columns in
a pipe, a log or a default terminal): cells wrap between words and a word wider than its
column is folded onto the next line, never cut with an ellipsis, so no number is ever lost.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from rich import box
from rich.console import Console, ConsoleOptions, RenderResult
from rich.measure import Measurement
from rich.table import Table

from models.powerlaw import Prediction
from models.quantities import DERIVED_QUANTITIES, MODEL_QUANTITIES

if TYPE_CHECKING:  # only in signatures: the tables load no NumPy (rcb --help imports them)
    from supervisor.optimize.result import OperationResult, PlanResult

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


class _FoldingTable(Table):
    """A table whose every column wraps between words and folds a longer word: never cut.

    rich cuts a cell (``0.55…``) in a column that may not wrap or whose overflow is
    ``ellipsis`` (its default); here a narrow console costs lines, not digits.
    """

    def add_column(self, *args: Any, **kwargs: Any) -> None:
        """As :meth:`rich.table.Table.add_column`, with ``no_wrap`` off and ``overflow="fold"``."""
        super().add_column(*args, **{**kwargs, "no_wrap": False, "overflow": "fold"})

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
    """Column widths for a table wider than the console, or None (it fits, or only folding does).

    Each column gets its longest word (a number is one word) or its ``min_width``, the rest of
    the width goes to the columns in proportion to what they lack of their natural width.
    """
    if any(column.width is not None for column in table.columns):
        return None
    wide = options.update(max_width=10**6)
    ranges = []
    for column in table.columns:
        cells = [Measurement.get(console, wide, c) for c in (column.header, *column.cells)]
        low, high = max(m.minimum for m in cells), max(m.maximum for m in cells)
        low = max(low, min(column.min_width or 0, high))  # a phrase kept on one line
        ranges.append((low, high))
    least, most = sum(r[0] for r in ranges), sum(r[1] for r in ranges)
    room = options.max_width - (Measurement.get(console, wide, table).maximum - most)
    if most <= room or least > room:
        return None
    share = (room - least) / (most - least)
    return [low + int(share * (high - low)) for low, high in ranges]


def new_table(*headings: str, **options: Any) -> Table:
    """A CLI table: a rule under the headings, no frame, two spaces between columns.

    ``headings`` and ``options`` (``title``, ``caption`` ...) as :class:`rich.table.Table`'s.
    """
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
