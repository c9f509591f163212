"""The SVG elements of one :class:`api.report.chart.Mark`, in a panel's pixel coordinates.

A :class:`Scale` maps part numbers and values to pixels; :func:`mark_svg` writes a mark as
one element (a path or a polyline: a hundred parts are one element, not a hundred) and
:func:`marker_defs` the shapes that points and legend entries refer to by id. Coordinates
are written with one decimal of a pixel; NaN values draw nothing (a gap).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

from api.report.chart import Mark, Marker
from api.report.html_parts import escaped

#: The shapes of point markers, centred on 0, 0 [px].
MARKER_PATHS: dict[Marker, str] = {
    "dot": "M-2.5 0a2.5 2.5 0 1 0 5 0a2.5 2.5 0 1 0-5 0z",
    "open": "M-2.5 0a2.5 2.5 0 1 0 5 0a2.5 2.5 0 1 0-5 0z",
    "cross": "M-4-4L4 4M-4 4L4-4",
    "triangle": "M-3.5-3L3.5-3L0 3.5z",
    "diamond": "M0-4.5L4.5 0L0 4.5L-4.5 0z",
}
#: Markers drawn as strokes (no fill) and the width of their stroke [px].
STROKED: dict[Marker, float] = {"cross": 2.0, "open": 1.2}
#: The width of a ``ranges`` bar and its least height, so that one value reads as a dot [px].
RANGE_PX = 2.0


@dataclass(frozen=True)
class Scale:
    """Data to pixels.

    x from ``x_range`` onto ``left..right``, y from ``y_range`` onto ``bottom..top`` (pixels
    grow downwards).
    """

    x_range: tuple[float, float]
    y_range: tuple[float, float]
    left: float
    right: float
    top: float
    bottom: float

    def x(self, value: float) -> float:
        """The pixel column of part number ``value``."""
        low, high = self.x_range
        return self.left + (value - low) / (high - low) * (self.right - self.left)

    def y(self, value: float) -> float:
        """The pixel row of ``value``."""
        low, high = self.y_range
        return self.bottom - (value - low) / (high - low) * (self.bottom - self.top)


def px(value: float) -> str:
    """A pixel coordinate with one decimal, no trailing zeros (``12``, ``12.5``)."""
    text = f"{value:.1f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def marker_id(prefix: str, marker: Marker, color: str) -> str:
    """The id of the ``<marker>`` of a shape in a colour."""
    return f"{prefix}mk-{marker}-{color.lstrip('#')}"


def marker_defs(prefix: str, used: set[tuple[Marker, str]]) -> str:
    """``<defs>``: each shape once (an id), each (shape, colour) once as an SVG ``<marker>``."""
    shapes = sorted({m for m, _ in used})
    out = [f'<path id="{prefix}shape-{m}" d="{MARKER_PATHS[m]}"/>' for m in shapes]
    for marker, color in sorted(used):
        out.append(
            f'<marker id="{marker_id(prefix, marker, color)}" markerUnits="userSpaceOnUse" '
            f'viewBox="-6 -6 12 12" markerWidth="12" markerHeight="12" overflow="visible">'
            f"{use_shape(prefix, marker, color, 0.0, 0.0)}</marker>"
        )
    return f"<defs>{''.join(out)}</defs>" if out else ""


def use_shape(prefix: str, marker: Marker, color: str, x: float, y: float) -> str:
    """A marker's shape at ``x, y`` (in a legend, or inside its ``<marker>``)."""
    if marker in STROKED:
        paint = f'fill="{"#fff" if marker == "open" else "none"}" stroke="{color}" '
        paint += f'stroke-width="{STROKED[marker]}"'
    else:
        paint = f'fill="{color}" stroke="#000" stroke-width="0.5"'
        if marker == "dot":
            paint = f'fill="{color}" stroke="none"'
    where = f' x="{px(x)}" y="{px(y)}"' if (x, y) != (0.0, 0.0) else ""
    return f'<use href="#{prefix}shape-{marker}"{where} {paint}/>'


def _runs(ys: list[float]) -> Iterator[list[int]]:
    """The indices of each run of consecutive finite values."""
    run: list[int] = []
    for i, y in enumerate(ys):
        if math.isfinite(y):
            run.append(i)
        elif run:
            yield run
            run = []
    if run:
        yield run


def _steps(run: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """A step per point centred on it (matplotlib's ``steps-mid``)."""
    out = [run[0]]
    for (x0, y0), (x1, y1) in zip(run, run[1:], strict=False):
        middle = (x0 + x1) / 2
        out += [(middle, y0), (middle, y1)]
    out.append(run[-1])
    return out


def _simplified(points: list[tuple[float, float]]) -> list[tuple[str, str]]:
    """The points as written (one decimal), without repeats.

    The middle of three points on one horizontal or vertical is dropped: a setpoint held
    for 100 parts is one segment.
    """
    out: list[tuple[str, str]] = []
    for x, y in points:
        point = (px(x), px(y))
        if out and point == out[-1]:
            continue
        if len(out) >= 2 and any(out[-2][k] == out[-1][k] == point[k] for k in (0, 1)):
            out[-1] = point
        else:
            out.append(point)
    return out


def _d(points: list[tuple[float, float]], close: bool = False) -> str:
    """Path data through ``points``: ``M``, then ``H``, ``V`` or ``L`` to each next one."""
    (x0, y0), *rest = _simplified(points)
    text, last = [f"M{x0} {y0}"], (x0, y0)
    for x, y in rest:
        if y == last[1]:
            text.append(f"H{x}")
        elif x == last[0]:
            text.append(f"V{y}")
        else:
            text.append(f"L{x} {y}")
        last = (x, y)
    return "".join(text) + ("z" if close else "")


def _dash(mark: Mark) -> str:
    if mark.dashed:
        return ' stroke-dasharray="5 3"'
    return ' stroke-dasharray="1.5 2"' if mark.dotted else ""


def mark_svg(mark: Mark, scale: Scale, prefix: str) -> str:
    """The mark as one SVG element (empty if it has no finite value)."""
    gid = f' id="{prefix}{escaped(mark.gid)}"' if mark.gid else ""
    xs = [scale.x(float(v)) for v in mark.x]
    ys = [scale.y(float(v)) if math.isfinite(v) else math.nan for v in mark.y]
    if mark.kind == "vlines":
        top, bottom = px(scale.top), px(scale.bottom)
        d = "".join(f"M{px(x)} {top}V{bottom}" for x in xs)
        return f'<path{gid} d="{d}" stroke="{mark.color}" stroke-width="1"{_dash(mark)}/>'
    if mark.kind == "hline":
        y = px(scale.y(float(mark.y[0])))
        return (
            f'<line{gid} x1="{px(scale.left)}" x2="{px(scale.right)}" y1="{y}" y2="{y}" '
            f'stroke="{mark.color}" stroke-width="1.2"{_dash(mark)}/>'
        )
    if mark.kind in ("band", "bars", "ranges"):
        if mark.y2 is None:
            raise ValueError(f"mark kind = {mark.kind!r}: needs y2, the other edge")
        y2 = [scale.y(float(v)) if math.isfinite(v) else math.nan for v in mark.y2]
        if mark.kind == "band":
            return _band(mark, xs, ys, y2, gid)
        if mark.kind == "ranges":
            return _ranges(xs, ys, y2, gid, mark.color)
        return _bars(xs, ys, y2, gid, mark.color)
    runs = [[(xs[i], ys[i]) for i in run] for run in _runs(ys)]
    if not runs:
        return ""
    if mark.kind == "points":
        points = " ".join(f"{px(x)},{px(y)}" for run in runs for x, y in run)
        ref = f"url(#{marker_id(prefix, mark.marker, mark.color)})"
        return (
            f'<polyline{gid} points="{points}" fill="none" stroke="none" '
            f'marker-start="{ref}" marker-mid="{ref}" marker-end="{ref}"/>'
        )
    shaped = [_steps(r) if mark.kind == "steps" else r for r in runs]
    d = "".join(_d(r) for r in shaped)
    return f'<path{gid} d="{d}" fill="none" stroke="{mark.color}" stroke-width="1.2"{_dash(mark)}/>'


def _band(mark: Mark, xs: list[float], low: list[float], high: list[float], gid: str) -> str:
    both = [lo if math.isfinite(hi) else math.nan for lo, hi in zip(low, high, strict=True)]
    d = ""
    for run in _runs(both):
        bottom = _steps([(xs[i], low[i]) for i in run])
        top = _steps([(xs[i], high[i]) for i in run])
        d += _d(bottom + top[::-1], close=True)
    if not d:
        return ""
    return f'<path{gid} d="{d}" fill="{mark.color}" fill-opacity="0.2" stroke="none"/>'


def _bars(xs: list[float], low: list[float], high: list[float], gid: str, color: str) -> str:
    d = "".join(
        f"M{px(x)} {px(lo)}V{px(hi)}"
        for x, lo, hi in zip(xs, low, high, strict=True)
        if math.isfinite(lo) and math.isfinite(hi)
    )
    return f'<path{gid} d="{d}" stroke="{color}" stroke-width="1"/>' if d else ""


def _ranges(xs: list[float], low: list[float], high: list[float], gid: str, color: str) -> str:
    """Thick bars, each at least :data:`RANGE_PX` tall: a range of one value is a dot."""
    d = ""
    for x, lo, hi in zip(xs, low, high, strict=True):
        if math.isfinite(lo) and math.isfinite(hi):
            bottom, top = max(lo, hi), min(lo, hi)
            middle, half = (bottom + top) / 2, max(bottom - top, RANGE_PX) / 2
            d += f"M{px(x)} {px(middle + half)}V{px(middle - half)}"
    if not d:
        return ""
    return f'<path{gid} d="{d}" stroke="{color}" stroke-width="{px(RANGE_PX)}"/>'
