"""A chart as SVG text for an HTML page: drawn directly, deterministic, small, ids unique.

:func:`render` calls a ``*_figure`` function of :mod:`api.report.plots` and :func:`to_svg`
draws the :class:`api.report.chart.Chart` it returns: panels stacked on one part axis, each
with its frame, grid, ticks, y label, marks (:mod:`api.report.svg_marks`) and a legend on
its right. Text stays text; every id starts with ``id_prefix`` so that several SVGs in one
page have unique ids; the same chart gives the same bytes.

The report drew its 25 plots with matplotlib until issue 30: 0.2-0.5 s a plot, 8.5 s of the
10.5 s a 100-part report took. Drawn here they take a few milliseconds each
(``benchmarks/report_speed.py``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from typing import TypeVar

import numpy as np

from api.report.chart import Chart, Mark, Panel, nice_ticks
from api.report.html_parts import escaped
from api.report.svg_marks import RANGE_PX, Scale, mark_svg, marker_defs, px, use_shape

S = TypeVar("S")

#: The chart's width, the y-axis margin on the left, the legend's width on the right [px].
WIDTH_PX, LEFT_PX, LEGEND_PX = 800.0, 84.0, 230.0
#: Height of a panel, gap between panels, room for a title, room for the x axis [px].
PANEL_PX, GAP_PX, TITLE_PX, BOTTOM_PX = 140.0, 14.0, 24.0, 38.0
#: Font sizes of labels and of tick values [px]; height of a legend entry [px].
FONT_PX, TICK_FONT_PX, ENTRY_PX = 11.0, 10.0, 14.0
#: Fonts named in every SVG.
FONT_FAMILY = "DejaVu Sans, Arial, Helvetica, sans-serif"


def to_svg(chart: Chart, id_prefix: str = "") -> str:
    """The chart as an SVG element (no XML declaration or DOCTYPE).

    Parameters
    ----------
    chart : Chart
        Its panels share the part axis.
    id_prefix : str
        Put before every id and reference to one (``op1-outputs`` gives ids
        ``op1-outputs-…``); letters, digits, ``-`` and ``_`` only.
    """
    if not re.fullmatch(r"[A-Za-z0-9_-]*", id_prefix):
        raise ValueError(f"id_prefix = {id_prefix!r}: letters, digits, - and _ only")
    prefix = f"{id_prefix}-" if id_prefix else ""
    top = TITLE_PX if chart.title else 8.0
    height = top + len(chart.panels) * (PANEL_PX + GAP_PX) - GAP_PX + BOTTOM_PX
    x_range, x_ticks = _x_axis(chart)
    used = {(m.marker, m.color) for p in chart.panels for m in p.marks if m.kind == "points"}
    body = [marker_defs(prefix, used)]
    if chart.title:
        body.append(_text(WIDTH_PX / 2, 16, chart.title, anchor="middle", weight="bold"))
    for i, panel in enumerate(chart.panels):
        panel_top = top + i * (PANEL_PX + GAP_PX)
        last = i == len(chart.panels) - 1
        body.append(_panel(panel, x_range, x_ticks, panel_top, prefix, last))
    body.append(_text(LEFT_PX + _plot_width() / 2, height - 6, chart.xlabel, anchor="middle"))
    return (
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{px(WIDTH_PX)}" height="{px(height)}" '
        f'viewBox="0 0 {px(WIDTH_PX)} {px(height)}" font-family="{FONT_FAMILY}" '
        f'font-size="{px(FONT_PX)}" role="img" aria-label="{escaped(accessible_name(chart))}">'
        f"{''.join(body)}</svg>"
    )


def accessible_name(chart: Chart) -> str:
    """The chart's accessible name: its title, what each panel shows, and the parts it covers.

    A screen reader names the image by it (an SVG ``role="img"`` without one is announced as
    an unnamed image); the figure's caption then says what the marks are.
    """
    xs = [float(v) for p in chart.panels for m in p.marks if m.kind != "hline" for v in m.x]
    xs = [x for x in xs if math.isfinite(x)]
    parts = f", parts {min(xs):g} to {max(xs):g}" if xs else ""
    shown = ", ".join(p.ylabel for p in chart.panels)
    return f"{chart.title}: {shown}{parts}" if chart.title else f"{shown}{parts}"


def render(draw: Callable[[S], Chart], series: S, id_prefix: str = "") -> str:
    """Draw ``series`` with ``draw`` (a ``*_figure`` function) as SVG (:func:`to_svg`)."""
    return to_svg(draw(series), id_prefix)


# --------------------------------------------------------------------------------------------
# axes


def _plot_width() -> float:
    return WIDTH_PX - LEFT_PX - LEGEND_PX - 10.0


def _x_axis(chart: Chart) -> tuple[tuple[float, float], list[float]]:
    """The part axis: every x of every mark, half a part on each side; integer ticks."""
    xs = [float(v) for p in chart.panels for m in p.marks if m.kind != "hline" for v in m.x]
    low, high = (min(xs), max(xs)) if xs else (0.0, 1.0)
    ticks = [t for t in nice_ticks(low, high, 8) if t == int(t) and low <= t <= high]
    pad = max(0.5, (high - low) * 0.02)
    return (low - pad, high + pad), ticks or [low]


def _y_values(panel: Panel) -> list[float]:
    values: list[float] = []
    for mark in panel.marks:
        for array in (mark.y, mark.y2):
            if array is not None:
                values += [float(v) for v in np.asarray(array) if math.isfinite(v)]
    return values


def _y_axis(panel: Panel) -> tuple[tuple[float, float], list[float]]:
    values = _y_values(panel) or [0.0, 1.0]
    low, high = min(values), max(values)
    if panel.from_zero:
        low = min(0.0, low)
    ticks = nice_ticks(low, high, 6)
    return (ticks[0], ticks[-1]), ticks


def tick_label(value: float) -> str:
    """A tick value: thousands separated from 10 000, else as short as it is exact."""
    if abs(value) >= 1e4:
        return f"{value:,.0f}"
    return f"{value:.6g}"


def _panel(
    panel: Panel,
    x_range: tuple[float, float],
    x_ticks: list[float],
    top: float,
    prefix: str,
    last: bool,
) -> str:
    y_range, y_ticks = _y_axis(panel)
    right = LEFT_PX + _plot_width()
    scale = Scale(x_range, y_range, LEFT_PX, right, top, top + PANEL_PX)
    grid = "".join(f"M{px(LEFT_PX)} {px(scale.y(t))}H{px(right)}" for t in y_ticks)
    grid += "".join(f"M{px(scale.x(t))} {px(top)}V{px(top + PANEL_PX)}" for t in x_ticks)
    out = [
        f'<path d="{grid}" stroke="#000" stroke-opacity="0.12" stroke-width="1"/>',
        *(mark_svg(m, scale, prefix) for m in panel.marks),
        f'<rect x="{px(LEFT_PX)}" y="{px(top)}" width="{px(right - LEFT_PX)}" '
        f'height="{px(PANEL_PX)}" fill="none" stroke="#444" stroke-width="1"/>',
    ]
    out += [
        _text(LEFT_PX - 4, scale.y(t) + 3.5, tick_label(t), anchor="end", small=True)
        for t in y_ticks
    ]
    if last:
        out += [
            _text(scale.x(t), top + PANEL_PX + 13, tick_label(t), anchor="middle", small=True)
            for t in x_ticks
        ]
    middle = top + PANEL_PX / 2
    out.append(
        f'<text x="12" y="{px(middle)}" text-anchor="middle" font-size="{px(TICK_FONT_PX)}" '
        f'transform="rotate(-90 12 {px(middle)})">{escaped(panel.ylabel)}</text>'
    )
    out.append(_legend(panel, right + 10, top, prefix))
    return "".join(out)


# --------------------------------------------------------------------------------------------
# text and legend


def _text(
    x: float,
    y: float,
    text: str,
    *,
    anchor: str = "start",
    small: bool = False,
    weight: str | None = None,
) -> str:
    size = f' font-size="{px(TICK_FONT_PX)}"' if small else ""
    bold = f' font-weight="{weight}"' if weight else ""
    return (
        f'<text x="{px(x)}" y="{px(y)}" text-anchor="{anchor}"{size}{bold}>{escaped(text)}</text>'
    )


def _swatch(mark: Mark, x: float, y: float, prefix: str) -> str:
    """What a legend entry shows of its mark, 20 px wide, centred on ``y``."""
    if mark.kind == "points":
        return use_shape(prefix, mark.marker, mark.color, x + 10, y)
    if mark.kind == "band":
        return (
            f'<rect x="{px(x)}" y="{px(y - 4)}" width="20" height="8" fill="{mark.color}" '
            f'fill-opacity="0.2"/>'
        )
    dash = ' stroke-dasharray="5 3"' if mark.dashed else ""
    dash = ' stroke-dasharray="1.5 2"' if mark.dotted else dash
    if mark.kind in ("bars", "vlines", "ranges"):  # a vertical stroke, a range's thick
        width = f' stroke-width="{px(RANGE_PX)}"' if mark.kind == "ranges" else ""
        d = f"M{px(x + 10)} {px(y - 5)}V{px(y + 5)}"
        return f'<path d="{d}" stroke="{mark.color}"{width}{dash}/>'
    return f'<path d="M{px(x)} {px(y)}h20" stroke="{mark.color}" stroke-width="1.2"{dash}/>'


def _legend(panel: Panel, x: float, top: float, prefix: str) -> str:
    entries = [m for m in panel.marks if m.label]
    out = []
    for i, mark in enumerate(entries):
        y = top + 8 + i * ENTRY_PX
        out.append(_swatch(mark, x, y, prefix))
        out.append(_text(x + 26, y + 3.5, mark.label or "", small=True))
    return "".join(out)
