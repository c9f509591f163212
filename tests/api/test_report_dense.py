"""A year of parts in the report's plots (``rcb report --last 1000``): readable and bounded.

At 1000 parts a part is half a pixel wide; a 5 px marker and an error bar per part made the
readings and the bands after the RCB updates a black band (776 kB for the demonstration plan's
page, 262 kB at 100 parts). From ``plots.DENSE_FROM`` rows on they are drawn as the range of
each group of parts; flagged and quarantined parts keep a mark each. The series here are
synthetic (no database): 1000 parts with a drift, a few flags and one quarantined reading.
"""

from __future__ import annotations

import re

import numpy as np

from api.report import plots
from api.report.series import OperationSeries, Output
from api.report.svg import LEGEND_PX, TICK_FONT_PX, render

FLAGGED = (137, 502, 503, 871)  # row indices (part = index + 1)
CHECKED = (640,)
CHANGED = (311,)  # a regime_change note


def _series(parts: int, first_part: int = 1) -> OperationSeries:
    rows = parts + 1  # the parts, then the next part
    rng = np.random.default_rng(7)
    predicted = np.full(rows, 1870.0)
    band = np.full(rows, 130.0)
    measured = 1915.0 + 8.0 * rng.standard_normal(rows) + np.linspace(0, 40, rows)
    measured[-1] = np.nan
    flagged = np.zeros(rows, dtype=bool)
    checked = np.zeros(rows, dtype=bool)
    for i in FLAGGED:
        if i < parts:
            flagged[i] = True
            measured[i] = 2010.0
    for i in CHECKED:
        if i < parts:
            checked[i] = True
            measured[i] = 1200.0
    band_after = 400.0 + 200.0 * np.exp(-np.arange(rows) / 10.0)
    band_after[-1] = np.nan
    held = np.arange(rows) < 20
    changed = np.isin(np.arange(rows), CHANGED)
    output = Output(
        quantity="force_N",
        limit=2000.0,
        sense="max",
        predicted=predicted,
        band=band,
        measured=measured,
        uncertainty=np.where(np.isfinite(measured), 10.0, np.nan),
        band_after=band_after,
        flagged=flagged,
        checked=checked,
        held=held,
        changed=changed,
    )
    flat = np.full(rows, 0.32)
    return OperationSeries(
        name="rough-od",
        tool="T1",
        process="turning",
        serials=tuple(f"SN-{i:05d}" for i in range(parts)),
        versions=tuple(range(1, rows + 1)),
        parameters={"feed_mm_rev": flat},
        bounds={"feed_mm_rev": (0.1, 0.6)},
        outputs=(output,),
        mrr_cm3_min=np.full(rows, 191.0),
        time_min=np.full(rows, 0.45),
        first_part=first_part,
    )


def _markers(svg: str, shape: str) -> int:
    """The points drawn with the marker ``shape`` (a polyline's points carry its markers)."""
    count = 0
    polylines = r'<polyline points="([^"]*)"[^>]*marker-mid="url\(#([^)]*)\)'
    for points, ref in re.findall(polylines, svg):
        if f"-mk-{shape}-" in f"-{ref}":
            count += len(points.split())
    return count


def _subpaths(svg: str, color: str) -> list[int]:
    """The subpaths (``M`` commands) of each path of bars in ``color`` (not its legend's)."""
    paths = re.findall(rf'<path d="([^"]*)" stroke="{color}" stroke-width="[\d.]+"/>', svg)
    return [n for n in (d.count("M") for d in paths) if n > 1]


def test_readings_at_1000_parts_are_ranges_of_groups_not_a_marker_each():
    svg = render(plots.outputs_figure, _series(1000))
    assert _markers(svg, "dot") == 0  # was 1000: a black band 5 px markers wide
    # one path of ranges for the readings, at most DENSE_GROUPS of them (was 1000 ± u bars)
    black = _subpaths(svg, "#000")
    assert len(black) == 1
    assert black[0] <= plots.DENSE_GROUPS
    assert "measured, range of 7 parts" in svg


def test_flags_and_quarantined_readings_keep_a_mark_each_at_1000_parts():
    svg = render(plots.outputs_figure, _series(1000))
    assert _markers(svg, "cross") == len(FLAGGED)
    assert _markers(svg, "diamond") == len(CHECKED)
    bands = render(plots.bands_figure, _series(1000))
    assert _markers(bands, "cross") == len(FLAGGED)


def test_a_range_reaches_the_group_s_extremes():
    """An outlier inside a group is not averaged away: its range reaches it."""
    series = _series(1000)
    chart = plots.outputs_figure(series)
    (ranges,) = [m for m in chart.panels[0].marks if m.kind == "ranges"]
    assert ranges.y2 is not None
    assert np.nanmax(ranges.y2) == 2010.0  # the flagged readings
    assert np.nanmin(ranges.y) == 1200.0  # the quarantined one
    assert len(ranges.x) <= plots.DENSE_GROUPS


def test_bands_after_the_updates_are_ranges_at_1000_parts():
    svg = render(plots.bands_figure, _series(1000))
    assert _markers(svg, "triangle") == 0  # was 1000: 980 green and 20 grey, overlapping
    assert len(_subpaths(svg, plots.UPDATE)) == 1
    assert len(_subpaths(svg, plots.BOUND)) == 1
    assert all(n <= plots.DENSE_GROUPS for n in _subpaths(svg, plots.UPDATE))


def test_the_1000_part_svgs_stay_within_twice_the_100_part_ones():
    for figure in (plots.outputs_figure, plots.bands_figure):
        small = len(render(figure, _series(100)).encode())
        large = len(render(figure, _series(1000)).encode())
        # was 5 times for the outputs: 31 kB at 1000 parts, 6 kB at 100
        assert large <= 2 * small, (figure.__name__, small, large)


def test_100_parts_keep_a_marker_and_a_bar_per_part():
    svg = render(plots.outputs_figure, _series(100))
    assert _markers(svg, "dot") == 100
    bands = render(plots.bands_figure, _series(100))
    assert _markers(bands, "triangle") == 100
    assert "range of" not in svg + bands


def _width(text: str, font_px: float) -> float:
    """A generous estimate of a label's width: DejaVu Sans digits and letters are 0.64 em."""
    return len(text) * 0.64 * font_px


def test_tick_labels_of_the_part_axis_do_not_overlap():
    for first in (1, 9_001, 998_001):
        svg = render(plots.outputs_figure, _series(1000, first_part=first))
        tick = r'<text x="([\d.]+)" y="[\d.]+" text-anchor="middle" font-size="10">([\d,]+)<'
        ticks = [(float(x), label) for x, label in re.findall(tick, svg)]
        assert len(ticks) >= 3, first
        spans = sorted(
            (x - _width(t, TICK_FONT_PX) / 2, x + _width(t, TICK_FONT_PX) / 2) for x, t in ticks
        )
        for (_, right), (left, _) in zip(spans, spans[1:], strict=False):
            assert right + 4 <= left, (first, spans)


def test_legend_entries_fit_the_legend_at_1000_parts():
    for figure in (plots.outputs_figure, plots.bands_figure):
        chart = figure(_series(1000))
        for panel in chart.panels:
            for mark in panel.marks:
                if mark.label:
                    assert 26 + _width(mark.label, TICK_FONT_PX) * 0.9 <= LEGEND_PX, mark.label


def test_a_change_of_the_process_keeps_its_rule_at_1000_parts():
    series = _series(1000)
    for figure in (plots.outputs_figure(series), plots.bands_figure(series)):
        (rule,) = [m for m in figure.panels[0].marks if m.kind == "vlines"]
        assert list(rule.x) == [i + 1 for i in CHANGED]
        svg = render(lambda s, f=figure: f, series)
        assert svg.count(f'stroke="{plots.CHANGE}"') == 2  # the rule and its legend swatch
