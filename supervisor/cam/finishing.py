"""Iso-parametric finishing paths on the compensated surface (Borangiu §3, Fig. 5).

"A tool path having the X parameter constant can be obtained by extracting a column from the
image. In the same way, a tool path with the Y parameter constant is obtained by extracting a
line from the image. Toolpaths that follow a constant direction in XY plane can be obtained
by first computing the points of the 2D line along that direction using the Bresenham
algorithm, and reading the grey values (heights) from these points." Here the heights are
read from the cutter's tip heights on the triangulated surface
(:mod:`supervisor.cam.dropcutter`), so the tip follows them and the cutter stays tangent to
the model; :func:`skimage.draw.line` is
Bresenham's line. The lines are ``stepover`` apart (rounded to whole pixels for X and Y).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from models.errors import InputError
from supervisor.cam.cutter import Cutter


def parse_direction(text: str, field: str = "finish_direction") -> str | float:
    """``x`` (constant X), ``y`` (constant Y) or an angle in degrees from +X."""
    low = text.strip().lower()
    if low in ("x", "y"):
        return low
    try:
        angle = float(low)
    except ValueError:
        raise InputError(field, text, "must be x, y or an angle in degrees") from None
    if not math.isfinite(angle) or abs(angle) > 360:
        raise InputError(field, text, "the angle must be within ±360 degrees")
    return angle


def iso_lines(
    tip_mm: NDArray[np.float64], pixel_mm: float, stepover_mm: float, direction: str | float
) -> tuple[list[NDArray[np.float64]], float]:
    """The finishing lines as ``(n, 3)`` tip points [mm], and the stepover used [mm].

    Lines alternate in direction (zig-zag), each from one edge of the map to the other.
    """
    rows, cols = tip_mm.shape
    if direction in ("x", "y"):
        step = max(1, round(stepover_mm / pixel_mm))
        index = line_indices(rows if direction == "y" else cols, step)
        lines = []
        for k, i in enumerate(index):
            if direction == "y":
                rr = np.full(cols, i)
                cc = np.arange(cols)
            else:
                rr = np.arange(rows)
                cc = np.full(rows, i)
            line = _points(tip_mm, rr, cc, pixel_mm)
            lines.append(line if k % 2 == 0 else line[::-1])
        return lines, step * pixel_mm
    return _bresenham_lines(tip_mm, pixel_mm, stepover_mm, float(direction)), stepover_mm


def line_indices(count: int, step: int) -> list[int]:
    """The rows (or columns) of the lines: every ``step``-th, and the last."""
    index = list(range(0, count, step))
    if index[-1] != count - 1:
        index.append(count - 1)
    return index


def _points(
    tip_mm: NDArray[np.float64], rr: NDArray[np.intp], cc: NDArray[np.intp], pixel_mm: float
) -> NDArray[np.float64]:
    rows = tip_mm.shape[0]
    return np.column_stack((cc * pixel_mm, (rows - 1 - rr) * pixel_mm, tip_mm[rr, cc]))


def _bresenham_lines(
    tip_mm: NDArray[np.float64], pixel_mm: float, stepover_mm: float, angle_deg: float
) -> list[NDArray[np.float64]]:
    from skimage.draw import line

    rows, cols = tip_mm.shape
    a = math.radians(angle_deg)
    ux, uy = math.cos(a), math.sin(a)  # along the line, pixel units (x = col, y up)
    nx, ny = -uy, ux  # across
    corners = [(0, 0), (cols - 1, 0), (0, rows - 1), (cols - 1, rows - 1)]
    across = [cx * nx + cy * ny for cx, cy in corners]
    step = stepover_mm / pixel_mm
    lines: list[NDArray[np.float64]] = []
    offset = min(across)
    k = 0
    while offset <= max(across) + 1e-9:
        ends = _clip(offset, (ux, uy), (nx, ny), cols - 1, rows - 1)
        if ends is not None:
            (x0, y0), (x1, y1) = ends
            rr, cc = line(  # type: ignore[no-untyped-call]
                rows - 1 - round(y0), round(x0), rows - 1 - round(y1), round(x1)
            )
            ok = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
            pts = _points(tip_mm, rr[ok], cc[ok], pixel_mm)
            if len(pts) >= 2:
                lines.append(pts if k % 2 == 0 else pts[::-1])
                k += 1
        offset += step
    return lines


def _clip(
    offset: float, u: tuple[float, float], n: tuple[float, float], width: float, height: float
) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """The part of the line ``{p : p·n = offset}`` inside ``[0, width] × [0, height]``."""
    px, py = offset * n[0], offset * n[1]
    lo, hi = -math.inf, math.inf
    for p, d, top in ((px, u[0], width), (py, u[1], height)):
        if abs(d) < 1e-12:
            if p < -1e-9 or p > top + 1e-9:
                return None
            continue
        t0, t1 = (0 - p) / d, (top - p) / d
        lo, hi = max(lo, min(t0, t1)), min(hi, max(t0, t1))
    if hi < lo:
        return None
    return (px + lo * u[0], py + lo * u[1]), (px + hi * u[0], py + hi * u[1])


def scallop_height_mm(cutter: Cutter, stepover_mm: float) -> float:
    """Cusp height between two passes on a flat surface [mm].

    ``h = r − sqrt(r² − (w/2)²)`` for a corner radius ``r``, with ``w`` the part of the
    stepover the corner must span (the stepover less the flat bottom ``2(R − r)``); 0 when the
    flat bottom spans it. Sandvik Coromant, "Milling formulas: scallop height".
    """
    flat = 2 * (cutter.radius_mm - cutter.corner_radius_mm)
    span = stepover_mm - flat
    if span <= 0:
        return 0.0
    r = cutter.corner_radius_mm
    half = min(span / 2, r)
    return r - math.sqrt(r * r - half * half)
