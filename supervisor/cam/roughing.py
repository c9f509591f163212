"""Constant-Z roughing with a flat end mill: contours, offsets, rings (Borangiu §3, Fig. 4).

At each level ``z`` the allowance surface ``s_a`` (:func:`supervisor.cam.compensation.
offset_surface`, the model grown by the stock allowance ``a`` in 3D) is thresholded,
its contours found (:func:`supervisor.cam.contours.islands`) and offset by the tool radius
``R`` (shapely's buffer): "the offsets are computed using a larger cutter radius, i.e. by
adding the offset value to the actual cutter radius" (Borangiu §3); here the allowance part
of that offset is the ball dilation, so a convex edge keeps ``a`` too. The material outside
is cleared by rings at the distances ``R, R + s, R + 2s, ...`` from the contour (``s`` the
stepover), cut from the outermost in: the first ring is placed so that it engages at most
``s`` of material, each next one ``s`` more, so no ring takes more than the radial depth its
setpoint was chosen for. A main level clears the whole stock outside the contour; a rest
level only the terrace between its contour and the main level's below it
(:mod:`supervisor.cam.levels`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy import ndimage
from shapely.geometry import LineString, Polygon, box
from shapely.geometry.base import BaseGeometry

from supervisor.cam.contours import LEVEL_EPS_MM, Window, islands, mask_window
from supervisor.cam.levels import Level

#: Segments per quarter circle of shapely's buffers.
QUAD_SEGS = 16
#: Path pieces shorter than this are dropped [mm].
MIN_PIECE_MM = 1e-3

Polyline = NDArray[np.float64]  # (n, 2) tool-centre x, y [mm]
#: A main level as the rest levels above it need it: its part, its mask and their window.
_Below = tuple[BaseGeometry, NDArray[np.bool_], Window | None]


@dataclass(frozen=True)
class LevelPaths:
    """The tool-centre paths of one roughing level, in cutting order."""

    level: Level
    paths: tuple[Polyline, ...]

    @property
    def length_mm(self) -> float:
        """Length of the cutting moves [mm]."""
        return float(sum(np.hypot(*np.diff(p, axis=0).T).sum() for p in self.paths))


def rough(
    surface_mm: NDArray[np.float64],
    pixel_mm: float,
    levels: list[Level],
    radius_mm: float,
    stepover_mm: float,
    progress: Callable[[int], None] | None = None,
) -> list[LevelPaths]:
    """The rings of every level (module docstring).

    Parameters
    ----------
    surface_mm : ndarray
        The allowance surface ``s_a`` [mm].
    pixel_mm : float
        Pixel size [mm].
    levels : list of Level
        In cutting order (:func:`supervisor.cam.levels.roughing_levels`).
    radius_mm : float
        The flat end mill's radius [mm].
    stepover_mm : float
        Distance between rings, at most the radius [mm].
    progress : callable, optional
        Called with the number of levels done.
    """
    rows, cols = surface_mm.shape
    stock = box(0.0, 0.0, (cols - 1) * pixel_mm, (rows - 1) * pixel_mm)
    chord = radius_mm * (1 - math.cos(math.pi / (4 * QUAD_SEGS)))
    reach_r = radius_mm + chord
    out: list[LevelPaths] = []
    below_cache: dict[float, _Below] = {}
    below_grown: dict[float, BaseGeometry] = {}
    for done, level in enumerate(levels, start=1):
        if level.kind == "main":
            paths, below = _main_paths(surface_mm, pixel_mm, level, stock, reach_r, stepover_mm)
            below_cache = {level.z_mm: below}
        else:
            below = below_cache[level.below_mm]
            if below[2] is None:
                out.append(LevelPaths(level, ()))
                continue
            paths = _rest_paths(
                surface_mm, pixel_mm, level, below, below_grown, reach_r, stepover_mm
            )
        out.append(LevelPaths(level, tuple(paths)))
        if progress is not None:
            progress(done)
    return out


def _main_paths(
    surface_mm: NDArray[np.float64],
    pixel_mm: float,
    level: Level,
    stock: BaseGeometry,
    reach_r: float,
    stepover_mm: float,
) -> tuple[list[Polyline], _Below]:
    """A main level's rings, clearing the whole stock outside its part; and what rests need."""
    mask = surface_mm > level.z_mm + LEVEL_EPS_MM
    window = mask_window(np.ones_like(mask), 0)
    part = islands(surface_mm, level.z_mm, pixel_mm)
    below = (part, mask, mask_window(mask, 2))
    reach = _farthest(mask, np.ones_like(mask), window, pixel_mm)
    return _rings(part, stock, reach, reach_r, stepover_mm, None), below


def _rest_paths(
    surface_mm: NDArray[np.float64],
    pixel_mm: float,
    level: Level,
    below: _Below,
    below_grown: dict[float, BaseGeometry],
    reach_r: float,
    stepover_mm: float,
) -> list[Polyline]:
    """A rest level's rings over the terrace between its part and the main level's below.

    ``below_grown`` keeps the main level's part grown by the reach, computed once for all the
    rest levels of that main level (only the latest main level's is kept).
    """
    below_part, _, below_window = below
    part = islands(surface_mm, level.z_mm, pixel_mm, below_window)
    region = below_part.difference(part)
    useful: BaseGeometry | None = None
    if not region.is_empty and shapely.contains_properly(below_part, part):
        if level.below_mm not in below_grown:
            below_grown.clear()
            below_grown[level.below_mm] = below_part.buffer(reach_r, quad_segs=QUAD_SEGS)
        useful = below_grown[level.below_mm].difference(part.buffer(-reach_r, quad_segs=QUAD_SEGS))
    reach = _farthest_vertex(region, part, pixel_mm, stepover_mm)
    return _rings(part, region, reach, reach_r, stepover_mm, useful)


def _farthest(
    mask: NDArray[np.bool_], material: NDArray[np.bool_], window: Window | None, pixel_mm: float
) -> float:
    """The largest distance from a material pixel to the part ``mask`` [mm] (+1 pixel)."""
    if window is None:
        return 0.0
    sl = (
        slice(window.row0, window.row0 + window.rows),
        slice(window.col0, window.col0 + window.cols),
    )
    part, mat = mask[sl], material[sl] & ~mask[sl]
    if not mat.any():
        return 0.0
    if not part.any():
        return float("inf")
    distance = ndimage.distance_transform_edt(~part)
    return float(distance[mat].max() + 1.0) * pixel_mm


def _farthest_vertex(
    region: BaseGeometry, part: BaseGeometry, pixel_mm: float, stepover_mm: float
) -> float:
    """A terrace's farthest vertex from the part, plus a stepover for points between [mm]."""
    if region.is_empty:
        return 0.0
    if part.is_empty:
        return float("inf")
    points = shapely.points(shapely.get_coordinates(region.boundary))
    return float(shapely.distance(points, part).max()) + stepover_mm + pixel_mm


def _rings(
    part: BaseGeometry,
    region: BaseGeometry,
    reach_mm: float,
    radius_mm: float,
    stepover_mm: float,
    useful: BaseGeometry | None = None,
) -> list[Polyline]:
    """Rings outside ``part`` at ``R + i·s`` from it, outermost first, clipped to what cuts.

    ``useful``: ``region`` grown by ``R``, if known (:func:`rough`).
    """
    if reach_mm <= 0 or region.is_empty:
        return []
    if useful is None:
        useful = region.buffer(radius_mm, quad_segs=QUAD_SEGS)
    if part.is_empty:
        return _inward(region, radius_mm, stepover_mm)
    count = max(0, math.ceil(reach_mm / stepover_mm) - 1)
    offsets = [part.buffer(radius_mm, quad_segs=QUAD_SEGS)]
    for _ in range(count):
        offsets.append(offsets[-1].buffer(stepover_mm, quad_segs=QUAD_SEGS))
    paths: list[Polyline] = []
    for grown in reversed(offsets):
        paths.extend(_pieces(grown.boundary.intersection(useful)))
    return paths


def _inward(region: BaseGeometry, radius_mm: float, stepover_mm: float) -> list[Polyline]:
    """No part at this level: clear ``region`` by rings from its outside in."""
    paths: list[Polyline] = []
    distance = radius_mm - stepover_mm
    while True:
        grown = region.buffer(distance, quad_segs=QUAD_SEGS)
        if grown.is_empty or grown.area <= 0:
            break
        paths.extend(_pieces(grown.boundary))
        distance -= stepover_mm
    return paths


def _pieces(geometry: BaseGeometry) -> list[Polyline]:
    """The line strings of a geometry as polylines, tiny ones dropped, pieces joined."""
    lines = [
        g
        for g in shapely.get_parts(shapely.line_merge(_lines(geometry)))
        if isinstance(g, LineString)
    ]
    return [np.asarray(g.coords, dtype=np.float64)[:, :2] for g in lines if g.length > MIN_PIECE_MM]


def _lines(geometry: BaseGeometry) -> BaseGeometry:
    parts = [g for g in shapely.get_parts(geometry) if isinstance(g, LineString)]
    parts += [
        LineString(g.exterior.coords) for g in shapely.get_parts(geometry) if isinstance(g, Polygon)
    ]
    return shapely.multilinestrings(parts) if parts else shapely.multilinestrings([])
