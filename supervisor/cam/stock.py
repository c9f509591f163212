"""The largest stock left on a roughed surface: its 3D distance to the model (verification).

:func:`remaining_stock` is exact on the pixel grid (the model as one plane patch per pixel)
and measured only where it can matter: the distance at a pixel is never more than the
vertical stock there, so the pixels are taken in decreasing vertical stock, a growing batch
at a time, until the largest distance found is at least the vertical stock of every pixel
left; a batch as large as a quarter of the map is measured over the whole map at once.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

#: The first batch of pixels measured [pixels]; each next one is four times larger.
FIRST_BATCH = 4096


def remaining_stock(
    model_mm: NDArray[np.float64],
    material_mm: NDArray[np.float64],
    pixel_mm: float,
    window_mm: float,
) -> float:
    """The largest distance from the material's surface to the model [mm].

    The model is taken as one plane patch per pixel (its square, tilted by the central-
    difference gradient): point samples alone would overstate the distance on a steep
    surface by up to half the spacing of the samples along it. For each pixel ``x`` of the
    material surface the distance to each patch within ``window_mm`` is that to the point of
    the patch nearest the point's projection on its plane (exact where the projection falls
    in the patch, an upper bound elsewhere); where no patch is within the window, the
    vertical stock ``m − s`` (an upper bound) is taken. Pixels are measured in decreasing
    vertical stock until none left can exceed the largest distance found (module docstring).
    """
    vertical = np.clip(material_mm - model_mm, 0.0, None)
    gy, gx = (np.asarray(g, dtype=np.float64) for g in np.gradient(model_mm, pixel_mm))
    gy = -gy  # rows run down, y up
    surface = (model_mm, material_mm, gx, gy, gx * gx + gy * gy)
    flat = vertical.ravel()
    order = np.argsort(-flat, kind="stable")
    found, done, batch = 0.0, 0, FIRST_BATCH
    while done < flat.size and flat[order[done]] > found:
        if batch >= flat.size // 4:
            return max(found, _whole(surface, vertical, pixel_mm, window_mm))
        take = order[done : done + batch]
        rows, cols = np.unravel_index(take, model_mm.shape)
        d2 = _nearest_squared(surface, rows, cols, pixel_mm, window_mm)
        found = max(found, float(_capped(np.sqrt(d2), flat[take], window_mm).max()))
        done += batch
        batch *= 4
    return found


def _capped(
    distance: NDArray[np.float64], vertical: NDArray[np.float64], window_mm: float
) -> NDArray[np.float64]:
    """At most the vertical stock; the vertical stock where nothing was within the window."""
    out = np.minimum(distance, vertical)
    return np.where(out > window_mm, vertical, out)


def _offsets(pixel_mm: float, window_mm: float) -> list[tuple[int, int]]:
    """The patches within the window of a pixel (and one pixel more), as (row, col) steps."""
    reach = int(math.ceil(window_mm / pixel_mm))
    return [
        (dy, dx)
        for dy in range(-reach, reach + 1)
        for dx in range(-reach, reach + 1)
        if (dy * dy + dx * dx) * pixel_mm**2 <= (window_mm + pixel_mm) ** 2
    ]


Surface = tuple[
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
]


def _patch_distance_squared(
    h: NDArray[np.float64],
    px: NDArray[np.float64],
    py: NDArray[np.float64],
    p2: NDArray[np.float64],
    wx: float,
    wy: float,
    half: float,
) -> NDArray[np.float64]:
    """Squared distance from a point ``h`` above a patch centre's height, ``(wx, wy)`` off it."""
    t = (px * wx + py * wy + h * p2) / (1 + p2)
    ux = np.clip(wx + (h - t) * px, -half, half)
    uy = np.clip(wy + (h - t) * py, -half, half)
    dz = h - (px * ux + py * uy)
    return np.asarray((wx - ux) ** 2 + (wy - uy) ** 2 + np.clip(dz, 0.0, None) ** 2)


def _nearest_squared(
    surface: Surface,
    rows: NDArray[np.intp],
    cols: NDArray[np.intp],
    pixel_mm: float,
    window_mm: float,
) -> NDArray[np.float64]:
    """Squared distance from the material at the given pixels to the nearest patch."""
    model, material, gx, gy, g2 = surface
    n_rows, n_cols = model.shape
    best = np.full(rows.shape, np.inf)
    top = material[rows, cols]
    for dy, dx in _offsets(pixel_mm, window_mm):
        # patch centre at row + dy, col + dx; w = x − y in mm (x right, y up)
        pr, pc = rows + dy, cols + dx
        ok = (pr >= 0) & (pr < n_rows) & (pc >= 0) & (pc < n_cols)
        pr, pc = pr[ok], pc[ok]
        d2 = _patch_distance_squared(
            top[ok] - model[pr, pc],
            gx[pr, pc],
            gy[pr, pc],
            g2[pr, pc],
            -dx * pixel_mm,
            dy * pixel_mm,
            pixel_mm / 2,
        )
        best[ok] = np.minimum(best[ok], d2)
    return best


def _whole(
    surface: Surface, vertical: NDArray[np.float64], pixel_mm: float, window_mm: float
) -> float:
    """:func:`remaining_stock` over every pixel, one shifted slice of the map per patch."""
    model, material, gx, gy, g2 = surface
    rows, cols = model.shape
    best = np.full(model.shape, np.inf)
    for dy, dx in _offsets(pixel_mm, window_mm):
        ys, yd = slice(max(0, dy), rows + min(0, dy)), slice(max(0, -dy), rows + min(0, -dy))
        xs, xd = slice(max(0, dx), cols + min(0, dx)), slice(max(0, -dx), cols + min(0, -dx))
        d2 = _patch_distance_squared(
            material[yd, xd] - model[ys, xs],
            gx[ys, xs],
            gy[ys, xs],
            g2[ys, xs],
            -dx * pixel_mm,
            dy * pixel_mm,
            pixel_mm / 2,
        )
        np.minimum(best[yd, xd], d2, out=best[yd, xd])
    return float(_capped(np.sqrt(best), vertical, window_mm).max())
