"""A thresholded height map as polygons: marching squares, then nesting (Borangiu §3, Fig. 4).

"First a binary image is obtained by thresholding the original greyscale surface at the desired
Z level. A contour detection algorithm is then applied for each binary image."
:func:`skimage.measure.find_contours` (marching squares) gives closed contours on the map
padded with a low border, the crossing interpolated between pixel centres (a contour of the
binary image instead would be a staircase whose notches a cutter cannot enter, leaving stock
there); a contour inside an odd number of others is a hole. The polygons are in mm
(:mod:`supervisor.cam.depthmap` axes).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry import MultiPolygon, Polygon
from shapely.geometry.base import BaseGeometry

#: A contour at a plateau's own height is ambiguous for marching squares; thresholds are
#: taken this far above the level asked for [mm] (it eats that much of the allowance).
LEVEL_EPS_MM = 1e-7
#: The contour is moved inward by this fraction of a pixel (``p``): where the surface jumps
#: past the threshold between two pixels (a wall on a floor), the interpolated contour runs
#: through the lower pixels' centres, a staircase whose dents (up to ``p/√2`` deep) a cutter
#: kept at its radius outside cannot enter, and those pixels, at the level itself, would
#: keep the stock of the level above. What this costs: the allowance, by ``0.75 p`` at most,
#: where the surface is barely above the threshold; never the model (a model point above the
#: threshold is at least the allowance inside the contour).
SHRINK_PX = 0.75
#: Then simplified (Douglas-Peucker) by this fraction of a pixel.
SIMPLIFY_PX = 0.1


@dataclass(frozen=True)
class Window:
    """A crop of the map: rows ``row0 .. row0 + rows − 1``, columns likewise."""

    row0: int
    col0: int
    rows: int
    cols: int


def mask_window(mask: NDArray[np.bool_], margin_px: int) -> Window | None:
    """The bounding box of ``mask`` grown by ``margin_px`` and cut to the map; None if empty."""
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0:
        return None
    cols = np.flatnonzero(mask.any(axis=0))
    r0 = max(0, int(rows[0]) - margin_px)
    c0 = max(0, int(cols[0]) - margin_px)
    r1 = min(mask.shape[0], int(rows[-1]) + margin_px + 1)
    c1 = min(mask.shape[1], int(cols[-1]) + margin_px + 1)
    return Window(r0, c0, r1 - r0, c1 - c0)


def islands(
    surface_mm: NDArray[np.float64], z_mm: float, pixel_mm: float, window: Window | None = None
) -> BaseGeometry:
    """The region where ``surface > z``, as a (multi)polygon in mm; empty if none.

    Parameters
    ----------
    surface_mm : ndarray
        Heights on the full map [mm].
    z_mm : float
        The threshold [mm].
    pixel_mm : float
        Pixel size [mm].
    window : Window, optional
        Look only inside this crop (it must hold every pixel above ``z``).
    """
    from skimage import measure

    z_mm = z_mm + LEVEL_EPS_MM
    full_rows = surface_mm.shape[0]
    w = window or Window(0, 0, surface_mm.shape[0], surface_mm.shape[1])
    crop = surface_mm[w.row0 : w.row0 + w.rows, w.col0 : w.col0 + w.cols]
    if not (crop > z_mm).any():
        return Polygon()
    # one ring of the edge pixels repeated, then a low one: a part that reaches the map's
    # edge gets its contour a pixel outside, so the inward move (SHRINK_PX) keeps the edge in
    low = min(float(crop.min()), z_mm) - 1.0
    padded = np.pad(np.pad(crop, 1, mode="edge"), 1, mode="constant", constant_values=low)
    found = measure.find_contours(  # type: ignore[no-untyped-call]
        padded, z_mm, fully_connected="high"
    )
    rings: list[Polygon] = []
    for c in found:
        if len(c) < 4:
            continue
        rows = c[:, 0] - 2 + w.row0
        cols = c[:, 1] - 2 + w.col0
        xy = np.column_stack((cols * pixel_mm, (full_rows - 1 - rows) * pixel_mm))
        poly = Polygon(xy)
        if not poly.is_valid:
            poly = shapely.make_valid(poly).buffer(0)
        if poly.area > 0:
            rings.append(poly)
    region = _nest(rings)
    tol = SIMPLIFY_PX * pixel_mm
    region = region.buffer(-SHRINK_PX * pixel_mm, quad_segs=4)
    simple = shapely.simplify(region, tol, preserve_topology=False)
    if simple.is_valid and not simple.is_empty:
        return simple
    return shapely.simplify(region, tol, preserve_topology=True)


def _nest(rings: list[Polygon]) -> BaseGeometry:
    """Polygons from closed contours: one inside an odd number of others is a hole."""
    if not rings:
        return Polygon()
    if len(rings) == 1:
        return rings[0]
    rings.sort(key=lambda p: p.area, reverse=True)
    tree = shapely.STRtree(rings)
    points = [p.representative_point() for p in rings]
    pairs = tree.query(points, predicate="within")  # (point index, containing ring index)
    containers: list[list[int]] = [[] for _ in rings]
    for i, j in zip(pairs[0], pairs[1], strict=True):
        if i != j:
            containers[int(i)].append(int(j))
    depth = [len(c) for c in containers]
    holes: dict[int, list[Polygon]] = {}
    for i, outer in enumerate(containers):
        if depth[i] % 2 == 1:
            parent = max(outer, key=lambda j: depth[j])
            holes.setdefault(parent, []).append(rings[i])
    parts: list[BaseGeometry] = []
    for i, ring in enumerate(rings):
        if depth[i] % 2 == 0:
            inner = holes.get(i)
            parts.append(ring.difference(shapely.union_all(inner)) if inner else ring)
    return shapely.union_all(parts) if len(parts) > 1 else parts[0]


def as_polygons(geometry: BaseGeometry) -> list[Polygon]:
    """The polygons of a geometry (a Polygon, a MultiPolygon or a collection)."""
    if isinstance(geometry, Polygon):
        return [] if geometry.is_empty else [geometry]
    if isinstance(geometry, MultiPolygon):
        return [p for p in geometry.geoms if not p.is_empty]
    return [p for p in shapely.get_parts(geometry) if isinstance(p, Polygon) and not p.is_empty]
