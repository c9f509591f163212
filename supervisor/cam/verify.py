"""Verification by simulation: the program swept over the height field.

The stock starts as a block up to the stock top. Each roughing level's feed moves (a flat end
mill at constant ``z``) sweep the region within ``R`` of the tool centre's path: the path,
arcs included, is buffered by ``R`` (shapely) and rasterised on the pixel centres
(:func:`skimage.draw.polygon`), and the material there is lowered to ``z``. The finishing
moves lower the material to ``min_y P(y) + h(|x − y|)``, ``P`` the tip heights along the path
and ``h`` the cutter's profile: a grey-scale erosion (:func:`scipy.ndimage.grey_erosion`).

The check is independent of the finishing compensation: that drops the cutter on the
triangulated surface at the path's points (:mod:`supervisor.cam.dropcutter`); this sweeps the
program as written and read back (rounded, straight moves between the points) and measures
the material against surface points the compensation never looked at one by one: the pixel
centres, and between them the midpoints of the triangles' diagonals (the centre of each
square of four pixel centres, at the mean of the diagonal's two heights), where a wall
steeper than the pixel grid stands. Reported: the largest gouge (material removed below the
model, at either kind of point), the largest stock left after roughing (the 3D distance from
the roughed surface to the model), the largest left after finishing, and the machining time
from the program's feeds.
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy import ndimage
from shapely.geometry import LineString, Point
from shapely.geometry.base import BaseGeometry

from supervisor.cam.contours import as_polygons
from supervisor.cam.cutter import Cutter
from supervisor.cam.motion import Segment
from supervisor.cam.stock import remaining_stock

#: Rapid traverse assumed for the cycle time (the plan gives none) [mm/min].
RAPID_MM_MIN = 10_000.0
#: Segments per quarter circle of the swept regions.
QUAD_SEGS = 16


@dataclass(frozen=True)
class Verification:
    """What the simulation found (module docstring) [mm, min]."""

    gouge_mm: float
    max_remaining_stock_mm: float
    max_finish_stock_mm: float | None
    cutting_time_min: float
    rapid_time_min: float
    rapids_below_stock: int

    @property
    def cycle_time_min(self) -> float:
        """Cutting and rapid time [min]."""
        return self.cutting_time_min + self.rapid_time_min


def machining_time(moves: list[Segment]) -> tuple[float, float]:
    """Cutting time at the programmed feeds and rapid time at :data:`RAPID_MM_MIN` [min]."""
    cutting = rapid = 0.0
    for m in moves:
        if not all(math.isfinite(v) for v in m.start):
            continue
        length = m.length_mm()
        if m.rapid:
            rapid += length / RAPID_MM_MIN
        elif length > 0:
            cutting += length / m.feed_mm_min
    return cutting, rapid


def simulate(
    model_mm: NDArray[np.float64],
    pixel_mm: float,
    stock_top_mm: float,
    moves: list[Segment],
    cutters: dict[int, Cutter],
    window_mm: float,
) -> Verification:
    """Sweep the program's moves (module docstring).

    Parameters
    ----------
    model_mm : ndarray
        The model's heights [mm].
    pixel_mm : float
        Pixel size [mm].
    stock_top_mm : float
        Top of the stock [mm].
    moves : list of Segment
        The program's moves (:func:`supervisor.cam.motion.read_moves`).
    cutters : dict
        The cutter of each tool number; a flat end mill roughs, any other finishes.
    window_mm : float
        How far to look for the model around a point of the roughed surface [mm]: beyond
        it the vertical stock (an upper bound of the distance) is taken.
    """
    sorted_moves = _sort_moves(moves, cutters, stock_top_mm)
    material = np.full(model_mm.shape, float(stock_top_mm))
    for z in sorted(sorted_moves.levels, reverse=True):
        row0, swept = _swept(
            sorted_moves.levels[z], sorted_moves.rough_radius_mm, model_mm.shape, pixel_mm
        )
        band = material[row0 : row0 + len(swept)]
        np.minimum(band, np.where(swept, z, np.inf), out=band)
    gouge = float(np.max(model_mm - material))
    stock = remaining_stock(model_mm, material, pixel_mm, window_mm)
    finish_stock: float | None = None
    if sorted_moves.finish_tool is not None and sorted_moves.finish:
        gouge, finish_stock = _finish_check(
            model_mm, material, sorted_moves.finish, sorted_moves.finish_tool, pixel_mm, gouge
        )
    cutting, rapid = machining_time(moves)
    return Verification(
        max(0.0, gouge), stock, finish_stock, cutting, rapid, sorted_moves.rapids_below
    )


@dataclass(frozen=True)
class _SortedMoves:
    """The program's moves by kind: roughing runs per level, finishing moves, rapids."""

    levels: dict[float, list[NDArray[np.float64]]]
    finish: list[NDArray[np.float64]]
    finish_tool: Cutter | None
    rapids_below: int
    rough_radius_mm: float


def _sort_moves(
    moves: list[Segment], cutters: dict[int, Cutter], stock_top_mm: float
) -> _SortedMoves:
    """Runs of a flat end mill at one ``z`` (a plunge starts one), the finishing moves apart.

    A rapid ends a run, and one that ends below the stock top is counted.
    """
    levels: dict[float, list[NDArray[np.float64]]] = defaultdict(list)
    finish: list[NDArray[np.float64]] = []
    finish_tool: Cutter | None = None
    rapids_below = 0
    run: list[tuple[float, float]] = []
    run_z: float | None = None
    rough_radius = 0.0

    def close_run() -> None:
        if run_z is not None and run:
            levels[run_z].append(np.asarray(run, dtype=np.float64))

    for m in moves:
        if m.rapid:
            close_run()
            run, run_z = [], None
            if math.isfinite(m.end[2]) and m.end[2] < stock_top_mm - 1e-9:
                rapids_below += 1
            continue
        cutter = cutters[m.tool]
        if cutter.kind == "flat" and m.start[2] == m.end[2]:
            rough_radius = cutter.radius_mm
            if run_z != m.end[2]:
                close_run()
                run, run_z = [m.start[:2]], m.end[2]
            run.extend(_vertices(m))
        elif cutter.kind == "flat" and m.start[:2] == m.end[:2]:  # a plunge
            close_run()
            run, run_z = [m.end[:2]], m.end[2]
        else:
            close_run()
            run, run_z = [], None
            finish_tool = cutter
            finish.append(np.asarray((m.start, m.end), dtype=np.float64))
    close_run()
    return _SortedMoves(levels, finish, finish_tool, rapids_below, rough_radius)


def _finish_check(
    model_mm: NDArray[np.float64],
    material: NDArray[np.float64],
    finish: list[NDArray[np.float64]],
    finish_tool: Cutter,
    pixel_mm: float,
    gouge: float,
) -> tuple[float, float]:
    """The finishing moves over the roughed ``material``: the gouge so far raised, stock left.

    The gouge is measured at the pixel centres and at the midpoints of the diagonals.
    """
    points = _pixel_points(finish, pixel_mm)
    material = np.minimum(material, _finished(points, finish_tool, model_mm.shape, pixel_mm, 0.0))
    gouge = max(gouge, float(np.max(model_mm - material)))
    finish_stock = float(np.max(material - model_mm))
    # between the pixel centres: the triangles' diagonals at their midpoints
    cells = _finished(points, finish_tool, model_mm.shape, pixel_mm, 0.5)[:-1, :-1]
    diagonal = 0.5 * (model_mm[:-1, :-1] + model_mm[1:, 1:])
    return max(gouge, float(np.max(diagonal - cells))), finish_stock


#: Largest gap between an arc and the chords it is swept as [mm].
ARC_CHORD_MM = 1e-3


def _vertices(m: Segment) -> list[tuple[float, float]]:
    """The XY points a constant-Z move passes, its start excluded: chords for an arc."""
    if m.centre is None:
        return [(m.end[0], m.end[1])]
    a0, a1, r = m.sweep()
    step = 2 * math.acos(max(-1.0, 1 - ARC_CHORD_MM / r)) if r > ARC_CHORD_MM else math.pi
    n = max(1, math.ceil(abs(a1 - a0) / step))
    angles = a0 + (a1 - a0) * np.arange(1, n + 1) / n
    xs = m.centre[0] + r * np.cos(angles)
    ys = m.centre[1] + r * np.sin(angles)
    xs[-1], ys[-1] = m.end[0], m.end[1]
    return list(zip(xs.tolist(), ys.tolist(), strict=True))


def _swept(
    runs: list[NDArray[np.float64]], radius_mm: float, shape: tuple[int, int], pixel_mm: float
) -> tuple[int, NDArray[np.bool_]]:
    """Pixel centres within ``radius_mm`` of any of the paths (:func:`fill_polygons`)."""
    lines = [LineString(r) for r in runs if len(r) > 1]
    points = [Point(r[0]) for r in runs if len(r) == 1]
    region = shapely.GeometryCollection(lines + points).buffer(radius_mm, quad_segs=QUAD_SEGS)
    return fill_polygons(region, shape, pixel_mm)


def fill_polygons(
    region: BaseGeometry, shape: tuple[int, int], pixel_mm: float
) -> tuple[int, NDArray[np.bool_]]:
    """Pixel centres inside ``region`` (even-odd over all its rings: holes stay empty).

    Returned as the first row of the rows the region covers and the mask of those rows
    (no pixel of another row is inside).

    A scanline fill: each ring edge gives the X where it crosses each pixel row's centre
    line (half-open in Y, so a vertex is counted once), and the pixels between successive
    crossings of a row are inside. Its cost grows with the rings' length in pixels, not with
    the area times the vertex count.
    """
    rows, cols = shape
    starts, ends = [], []
    for poly in as_polygons(region):
        for ring in [poly.exterior, *poly.interiors]:
            xy = np.asarray(ring.coords)[:, :2] / pixel_mm
            starts.append(xy[:-1])
            ends.append(xy[1:])
    if not starts:
        return 0, np.zeros((0, shape[1]), dtype=bool)
    a, b = np.vstack(starts), np.vstack(ends)
    y_low, y_high = np.minimum(a[:, 1], b[:, 1]), np.maximum(a[:, 1], b[:, 1])
    first = np.ceil(y_low).astype(np.int64)
    count = np.maximum(0, np.ceil(y_high).astype(np.int64) - first)
    keep = count > 0
    a, b, first, count = a[keep], b[keep], first[keep], count[keep]
    edge = np.repeat(np.arange(len(a)), count)
    offset = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    y = (first[edge] + offset).astype(np.float64)
    ax, ay, bx, by = a[edge, 0], a[edge, 1], b[edge, 0], b[edge, 1]
    x = ax + (y - ay) * (bx - ax) / (by - ay)
    order = np.lexsort((x, y))
    y, x = y[order], x[order]
    # crossings come in pairs per row: fill [ceil(x_in), ceil(x_out) - 1]
    x_in, x_out, row_y = x[0::2], x[1::2], y[0::2]
    c0 = np.clip(np.ceil(x_in).astype(np.int64), 0, cols)
    c1 = np.clip(np.ceil(x_out).astype(np.int64), 0, cols)
    r = rows - 1 - row_y.astype(np.int64)
    ok = (r >= 0) & (r < rows) & (c1 > c0)
    if not ok.any():
        return 0, np.zeros((0, cols), dtype=bool)
    r, c0, c1 = r[ok], c0[ok], c1[ok]
    first_row = int(r.min())
    band = int(r.max()) + 1 - first_row
    width = cols + 1
    diff = np.bincount((r - first_row) * width + c0, minlength=band * width)
    diff -= np.bincount((r - first_row) * width + c1, minlength=band * width)
    mask = np.cumsum(diff.reshape(band, width)[:, :cols], axis=1) > 0
    return first_row, mask


def _pixel_points(moves: list[NDArray[np.float64]], pixel_mm: float) -> NDArray[np.float64]:
    """The finishing moves' points one pixel step apart (their ends are pixel centres).

    ``moves``: each move's start and end (2, 3). Move ``k`` of ``n_k`` steps gives the points
    ``start + (i / n_k)(end − start)``, ``i = 0 .. n_k`` (the end exactly), all at once.
    """
    ends = np.stack(moves)  # (m, 2, 3)
    start, delta = ends[:, 0], ends[:, 1] - ends[:, 0]
    reach = np.maximum(np.abs(delta[:, 0]), np.abs(delta[:, 1])) / pixel_mm
    steps = np.maximum(1, np.rint(reach).astype(np.int64))
    move = np.repeat(np.arange(len(ends)), steps + 1)
    index = np.arange(len(move)) - np.repeat(np.cumsum(steps + 1) - (steps + 1), steps + 1)
    t = (index * (1.0 / steps[move]))[:, None]
    t[np.cumsum(steps + 1) - 1] = 1.0
    return np.asarray(start[move] + t * delta[move], dtype=np.float64)


def _finished(
    points: NDArray[np.float64],
    cutter: Cutter,
    shape: tuple[int, int],
    pixel_mm: float,
    offset_px: float,
) -> NDArray[np.float64]:
    """Material height after the finishing tip has passed through ``points``.

    At the pixel centres (``offset_px`` 0) or at the points ``offset_px`` pixels to the
    right of and below them (0.5: the squares' centres; the last row and column then fall
    off the map). The tip points are taken at the pixel centres nearest them.
    """
    big = 1.0e9
    tips = np.full(shape, big)
    cols = np.rint(points[:, 0] / pixel_mm).astype(int)
    rows = shape[0] - 1 - np.rint(points[:, 1] / pixel_mm).astype(int)
    inside = (rows >= 0) & (rows < shape[0]) & (cols >= 0) & (cols < shape[1])
    np.minimum.at(tips, (rows[inside], cols[inside]), points[inside, 2])
    # the cutter on the grid of tip positions around one target: tip row = target row + dr,
    # tip column = target column + o, at the distance from the target to the tip's axis
    reach = int(np.ceil(cutter.radius_mm / pixel_mm + offset_px + 1e-9))
    dr, o = np.mgrid[-reach : reach + 1, -reach : reach + 1]
    distance = np.hypot(o - offset_px, dr - offset_px) * pixel_mm
    footprint = distance <= cutter.radius_mm + 1e-9
    structure = np.where(footprint, -cutter.profile_mm(np.minimum(distance, cutter.radius_mm)), 0.0)
    # one kernel row at a time, from the rows the tip passed only (iso-lines along X pass
    # one row in a few): the same erosion, at that fraction of the cost
    visited = np.flatnonzero((tips < big).any(axis=1))
    out = np.full(shape, big)
    source = tips[visited]
    for k in range(footprint.shape[0]):
        if not footprint[k].any():
            continue
        part = ndimage.grey_erosion(
            source,
            footprint=footprint[k : k + 1],
            structure=structure[k : k + 1],
            mode="constant",
            cval=big,
        )
        dest = visited - (k - reach)
        ok = (dest >= 0) & (dest < shape[0])
        out[dest[ok]] = np.minimum(out[dest[ok]], part[ok])
    return out
