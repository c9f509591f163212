"""The plots drawn as SVG directly (api/report/chart.py, svg.py, svg_marks.py; issue 30).

What is drawn is read back from the SVG: a limit line's height, mapped through the y axis's
own tick labels, is the limit; every measured point is a vertex of the points' polyline; a
gap (NaN) splits a line; a setpoint held over 100 parts is one segment.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from api.report import plots
from api.report.chart import Chart, Mark, Panel, nice_ticks
from api.report.series import Output
from api.report.svg import render, tick_label, to_svg

SVG = "{http://www.w3.org/2000/svg}"


def _output(n: int = 5) -> Output:
    x = np.arange(n + 1, dtype=float)
    measured = np.append(1900.0 + 10 * x[:-1], np.nan)
    return Output(
        quantity="force_N",
        limit=2000.0,
        sense="max",
        predicted=np.full(n + 1, 1850.0),
        band=np.full(n + 1, 120.0),
        measured=measured,
        uncertainty=np.append(np.full(n, 3.0), np.nan),
        band_after=np.append(np.linspace(300, 200, n), np.nan),
        flagged=np.array([False, False, True, False, False, False][: n + 1]),
        checked=np.zeros(n + 1, dtype=bool),
        held=np.zeros(n + 1, dtype=bool),
        changed=np.zeros(n + 1, dtype=bool),
    )


def _chart(output: Output) -> Chart:
    x = np.arange(1, len(output.predicted) + 1, dtype=float)
    return Chart("t", plots.PART_AXIS, (Panel("force F [N]", plots._output_marks(x, output)),))


def _ticks(root: ET.Element) -> list[tuple[float, float]]:
    """(value, y px) of the y tick labels (right-aligned texts left of the panel)."""
    return [
        (float(t.text.replace(",", "")), float(t.get("y")) - 3.5)
        for t in root.iter(f"{SVG}text")
        if t.get("text-anchor") == "end" and t.text
    ]


def test_a_limit_line_is_drawn_at_the_limit():
    root = ET.fromstring(to_svg(_chart(_output()), "p"))
    (line,) = [e for e in root.iter(f"{SVG}line") if e.get("id") == "p-limit-force_N"]
    ticks = _ticks(root)
    values, ys = zip(*ticks, strict=True)
    assert len(ticks) >= 3 and values == tuple(sorted(values))
    drawn = np.interp(float(line.get("y1")), ys[::-1], values[::-1])  # y grows downwards
    assert_allclose(drawn, 2000.0, atol=0.5)  # 0.1 px of a 140 px panel over ~300 N
    assert line.get("stroke-dasharray")  # dashed, as the legend's swatch
    legend = [t.text for t in root.iter(f"{SVG}text")]
    assert "limit (maximum) 2000 N" in legend


def test_every_measured_point_is_a_vertex_and_the_flag_is_marked():
    output = _output()
    root = ET.fromstring(to_svg(_chart(output), "p"))
    polylines = list(root.iter(f"{SVG}polyline"))
    markers = {p.get("marker-mid"): p.get("points").split() for p in polylines}
    measured = markers["url(#p-mk-dot-000)"]
    assert len(measured) == 5  # the 5 parts; the next part has no reading
    flagged = markers["url(#p-mk-cross-d62728)"]
    assert len(flagged) == 1 and flagged[0] == measured[2]  # part 3, where it was measured
    ids = {e.get("id") for e in root.iter() if e.get("id")}
    refs = re.findall(r"url\(#([^)]*)\)|href=\"#([^\"]*)\"", to_svg(_chart(output), "p"))
    assert {a or b for a, b in refs} <= ids  # every reference resolves inside the SVG


def test_a_gap_splits_a_line_and_a_held_value_is_one_segment():
    x = np.arange(1.0, 101.0)
    held = Mark("steps", x, np.full(100, 5.0), "#000")
    gap = Mark("line", x[:5], np.array([1.0, 2.0, np.nan, 4.0, 5.0]), "#000")
    root = ET.fromstring(to_svg(Chart("", "part", (Panel("y", (held, gap)),))))
    paths = [p.get("d") for p in root.iter(f"{SVG}path") if p.get("fill") == "none"]
    held_d, gap_d = paths
    assert re.fullmatch(r"M[0-9.]+ [0-9.]+H[0-9.]+", held_d), held_d
    assert gap_d.count("M") == 2, gap_d


def test_nice_ticks_are_round_and_cover_the_range():
    assert nice_ticks(0.0123, 0.0571) == [0.01, 0.02, 0.03, 0.04, 0.05, 0.06]
    assert nice_ticks(0.0, 864_000.0) == [0.0, 200_000.0, 400_000.0, 600_000.0, 800_000.0, 1e6]
    for low, high in ((1850.0, 2000.0), (3.3, 3.3), (-2.0, 7.5), (1.0, 101.0)):
        ticks = nice_ticks(low, high)
        assert ticks[0] <= low and ticks[-1] >= high and 2 <= len(ticks) <= 8, (low, ticks)
        steps = np.diff(ticks)
        assert_allclose(steps, steps[0])
    assert tick_label(864_000.0) == "864,000" and tick_label(0.25) == "0.25"


def test_bad_id_prefix_is_refused_naming_it():
    with pytest.raises(ValueError, match="id_prefix = 'x\" onload'"):
        render(lambda _: Chart("", "", ()), None, 'x" onload')


def test_a_wider_band_held_is_drawn_apart_from_one_applied():
    held = np.array([True, True, False, False, False, False])
    output = replace(_output(), held=held)
    x = np.arange(1.0, 7.0)
    marks = {m.label: m for m in plots._band_marks(x, output)}
    applied = marks["ΔY after the part's RCB update"]
    kept = marks["ΔY learned, still wider: held"]
    assert np.isnan(applied.y[:2]).all()
    assert_allclose(applied.y[2:5], output.band_after[2:5])
    assert_allclose(kept.y[:2], output.band_after[:2])
    assert np.isnan(kept.y[2:]).all()
    assert applied.color != kept.color
    root = ET.fromstring(to_svg(Chart("", "", (Panel("band", tuple(marks.values())),)), "b"))
    drawn = {p.get("marker-mid"): len(p.get("points").split()) for p in root.iter(f"{SVG}polyline")}
    assert drawn["url(#b-mk-triangle-2ca02c)"] == 3 and drawn["url(#b-mk-triangle-666666)"] == 2
