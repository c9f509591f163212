"""Constant-Z roughing levels: the grey-level gradient rule (Borangiu et al., IFAC 2007, §3-4).

Borangiu: "by piecewise estimating the grey level gradient in the point depths range
``Z_0 ... Z_f``, the number of C cutting passes is computed ... with cutting depths ``Δ_j``,
such that ``Σ_j c_j·Δ_j = Z_f − Z_0`` and ``Σ_j c_j = C``", taking into account "both form
accuracy (piecewise change of the cutting depth ``Δ_j`` on grey level gradient basis) and
material characteristics (type and hardness of material impose upper limits on ``Δ_j``)".
The rule made concrete here, on the allowance surface ``s_a``
(:func:`supervisor.cam.compensation.offset_surface`, the model ``s`` grown by the allowance):

1. Breakpoints: the stock top ``Z_0``, every plateau of ``s_a`` (a grey level held by at least
   as many flat pixels as the roughing cutter covers) and the floor ``Z_f = min s_a``: a
   plateau is cut exactly at its height, never stepped over.
2. Material: between breakpoints ``U > L``, ``m = ceil((U − L) / ap_max)`` equal main passes,
   ``ap_max`` the largest axial depth the robust optimiser allows
   (:func:`supervisor.cam.feeds.cutting_limits`).
3. Form accuracy: a constant-Z level leaves a stair whose thickness normal to a surface of
   slope ``g`` is ``Δ / sqrt(1 + g²)``. The slope is read where the paper reads it, on the
   model's own grey levels (fourth-order central differences, :func:`slope_map`), not on
   ``s_a``: a ball dilation sampled on pixels is a few per cent off the true offset surface
   on a steep flank. The offset surface keeps the model's normals: a model pixel ``y`` of
   slope ``g`` carries the point of ``s_a`` at height ``s(y) + a / sqrt(1 + g²)`` (``a`` the
   allowance), of the same slope (:func:`offset_heights`). In each main pass ``(u, l]`` the
   least slope ``g_min`` over the model pixels whose point lies in ``l < z < u`` (not within
   two pixels of a plateau, where the differences average a wall and a floor) sets
   ``Δ_j <= ε · sqrt(1 + g_min²)`` (``ε`` the form tolerance), so the pass is split into
   ``c_j = ceil((u − l) / (ε sqrt(1 + g_min²)))`` equal steps ``Δ_j = (u − l) / c_j``; with no
   pixel in the pass (a vertical wall) ``c_j = 1``.

The main level ``l`` clears the whole area; the ``c_j − 1`` levels above it (*rest* levels,
cut after it, top down) clear only the terrace the main level left, so each level's depth of
cut is at most ``u − l <= ap_max``.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from models.errors import InputError

LevelKind = Literal["main", "rest"]
#: Heights closer than this are the same [mm].
Z_TOL_MM = 1e-9
#: The most levels one map may need; a finer rule is refused, naming the form tolerance.
MAX_LEVELS = 5000


@dataclass(frozen=True)
class Level:
    """One constant-Z roughing level.

    Parameters
    ----------
    z_mm : float
        Height of the cutter's bottom [mm].
    depth_mm : float
        The largest depth of cut at this level [mm]: from the level cut before it above
        (the main level ``above_mm`` for a rest level).
    kind : {"main", "rest"}
        A main level clears everything outside the part; a rest level the terrace between
        its own contour and the main level's below it (``below_mm``).
    above_mm, below_mm : float
        The main pass ``(below, above]`` the level belongs to [mm].
    slope : float or None
        ``g_min`` of the pass (None: no pixel in it).
    """

    z_mm: float
    depth_mm: float
    kind: LevelKind
    above_mm: float
    below_mm: float
    slope: float | None


@dataclass(frozen=True)
class Band:
    """``c_j`` passes of ``Δ_j`` (Borangiu §4: ``Σ c_j Δ_j = Z_0 − Z_f``)."""

    top_mm: float
    bottom_mm: float
    count: int
    step_mm: float
    slope: float | None


def slope_map(
    surface_mm: NDArray[np.float64], pixel_mm: float, grey_level_mm: float, tolerance_mm: float
) -> NDArray[np.float64]:
    """``|∇ s|`` by fourth-order central differences [mm/mm].

    ``(−s(x+2p) + 8 s(x+p) − 8 s(x−p) + s(x−2p)) / (12 p)`` per axis (Fornberg, 1988): on a
    sphere's steep flank the second-order difference reads a few per cent low, which moves
    the pass count of a band.

    A coarse grey level makes flat terraces of one grey level each; where one grey level is
    more than a tenth of the form tolerance the surface is first smoothed over the width of
    a terrace at a slope of 0.2 (``σ = q / (0.2 p)`` pixels, at most 10).
    """
    surface = surface_mm
    if grey_level_mm > tolerance_mm / 10:
        sigma = min(10.0, grey_level_mm / (0.2 * pixel_mm))
        surface = ndimage.gaussian_filter(surface_mm, sigma, mode="nearest")
    s = np.pad(surface, 2, mode="edge")
    gx = (-s[2:-2, 4:] + 8 * s[2:-2, 3:-1] - 8 * s[2:-2, 1:-3] + s[2:-2, :-4]) / (12 * pixel_mm)
    gy = (-s[4:, 2:-2] + 8 * s[3:-1, 2:-2] - 8 * s[1:-3, 2:-2] + s[:-4, 2:-2]) / (12 * pixel_mm)
    return np.asarray(np.hypot(gx, gy), dtype=np.float64)


def offset_heights(
    height_mm: NDArray[np.float64], slope: NDArray[np.float64], allowance_mm: float
) -> NDArray[np.float64]:
    """Height of the point of ``s_a`` each model pixel carries: ``s + a / sqrt(1 + g²)`` [mm].

    The ball of radius ``a`` touching the model at ``y`` has its top, the offset surface's
    point there, at ``a`` along the normal ``(−∇s, 1) / sqrt(1 + g²)``; that point has the
    model's slope ``g`` (module docstring, rule 3).
    """
    return np.asarray(height_mm + allowance_mm / np.hypot(1.0, slope), dtype=np.float64)


def plateaus(surface_mm: NDArray[np.float64], min_pixels: int) -> list[float]:
    """Heights held by at least ``min_pixels`` flat pixels (equal to their 4 neighbours)."""
    cross = ndimage.generate_binary_structure(2, 1)
    high = ndimage.grey_dilation(surface_mm, footprint=cross, mode="nearest")
    low = ndimage.grey_erosion(surface_mm, footprint=cross, mode="nearest")
    flat = (high - low) <= Z_TOL_MM
    values, counts = np.unique(np.round(surface_mm[flat], 9), return_counts=True)
    return [float(v) for v, c in zip(values, counts, strict=True) if c >= min_pixels]


def roughing_levels(
    surface_mm: NDArray[np.float64],
    height_mm: NDArray[np.float64],
    slope: NDArray[np.float64],
    allowance_mm: float,
    stock_top_mm: float,
    max_depth_mm: float,
    tolerance_mm: float,
    plateau_pixels: int,
) -> tuple[list[Level], list[Band]]:
    """The levels of the gradient rule (module docstring), in cutting order.

    Parameters
    ----------
    surface_mm : ndarray
        The allowance surface ``s_a`` [mm].
    height_mm : ndarray
        The model ``s`` [mm].
    slope : ndarray
        ``|∇ s|``, the model's slope (:func:`slope_map`).
    allowance_mm : float
        ``a``, the allowance ``s_a`` adds [mm].
    stock_top_mm : float
        ``Z_0`` [mm].
    max_depth_mm : float
        ``ap_max``, the largest axial depth allowed [mm].
    tolerance_mm : float
        ``ε``, the form tolerance [mm].
    plateau_pixels : int
        Flat pixels a plateau needs.

    Returns
    -------
    levels : list of Level
        Top down by main pass; in each, the main level, then its rest levels top down.
    bands : list of Band
        The ``(c_j, Δ_j)`` of each main pass.
    """
    marks = _breakpoints(surface_mm, stock_top_mm, plateau_pixels)
    breaks = sorted((m for m in marks if m <= float(stock_top_mm)), reverse=True)
    slope = _slope_off_plateaus(height_mm, slope, allowance_mm, marks)
    levels: list[Level] = []
    bands: list[Band] = []
    sorted_values, order, flat_slopes = _by_offset_height(height_mm, slope, allowance_mm)
    for upper, lower in zip(breaks[:-1], breaks[1:], strict=True):
        if upper - lower <= Z_TOL_MM:
            continue
        for u, low in _main_passes(upper, lower, max_depth_mm):
            g = _least_slope(sorted_values, order, flat_slopes, low, u)
            band, pass_levels = _split_pass(u, low, g, tolerance_mm)
            bands.append(band)
            levels.extend(pass_levels)
            if len(levels) > MAX_LEVELS:
                raise InputError(
                    "form_tolerance_mm",
                    tolerance_mm,
                    f"needs more than {MAX_LEVELS} roughing levels on this map; use a larger one",
                )
    return levels, bands


def _breakpoints(
    surface_mm: NDArray[np.float64], stock_top_mm: float, plateau_pixels: int
) -> set[float]:
    """Rule 1: the stock top, the floor and every plateau between them [mm]."""
    floor = float(surface_mm.min())
    top = float(stock_top_mm)
    marks = {top, floor}
    marks.update(h for h in plateaus(surface_mm, plateau_pixels) if floor < h < top - Z_TOL_MM)
    return marks


def _slope_off_plateaus(
    height_mm: NDArray[np.float64],
    slope: NDArray[np.float64],
    allowance_mm: float,
    marks: set[float],
) -> NDArray[np.float64]:
    """``slope`` made infinite within two pixels of a plateau and of the map's edge.

    A pixel beside a plateau (a wall's foot on a floor) has a central difference that averages
    the wall and the floor: not a slope of the surface, and the plateau is cut at its own
    height anyway.
    """
    # (a model pixel on a plateau of s_a is one at the plateau's height less the allowance)
    raised = np.round(height_mm + allowance_mm, 9)
    on_plateau = np.isin(raised, np.round(np.asarray(sorted(marks)), 9))
    beside = ndimage.binary_dilation(on_plateau, structure=np.ones((5, 5), dtype=bool))
    beside[:2, :] = beside[-2:, :] = True  # the stencil needs two pixels each side
    beside[:, :2] = beside[:, -2:] = True
    return np.where(beside, np.inf, slope)  # (their offset heights are then the raised model)


def _by_offset_height(
    height_mm: NDArray[np.float64], slope: NDArray[np.float64], allowance_mm: float
) -> tuple[NDArray[np.float64], NDArray[np.intp], NDArray[np.float64]]:
    """The model pixels' offset heights sorted, their order, and the slopes (all flattened).

    Sorted once, so that each pass finds its pixels by bisection (:func:`_least_slope`).
    """
    flat_values = offset_heights(height_mm, slope, allowance_mm).ravel()
    order = np.argsort(flat_values, kind="stable")
    return flat_values[order], order, slope.ravel()


def _main_passes(upper: float, lower: float, max_depth_mm: float) -> Iterator[tuple[float, float]]:
    """Rule 2: ``(u, l)`` of the ``ceil((U − L) / ap_max)`` equal main passes, top down.

    A generator: the caller stops at :data:`MAX_LEVELS` before a tiny ``ap_max`` makes many.
    """
    main = math.ceil((upper - lower) / max_depth_mm - 1e-9)
    step = (upper - lower) / main
    for i in range(main):
        yield upper - i * step, lower if i == main - 1 else upper - (i + 1) * step


def _split_pass(
    u: float, low: float, g: float | None, tolerance_mm: float
) -> tuple[Band, list[Level]]:
    """Rule 3: the main pass ``(low, u]`` in ``c_j`` equal steps; its main level, then rests."""
    count = 1 if g is None else math.ceil((u - low) / (tolerance_mm * math.hypot(1.0, g)) - 1e-9)
    count = max(count, 1)
    levels = [Level(low, u - low, "main", u, low, g)]
    for k in range(1, count):
        z = u - k * (u - low) / count
        levels.append(Level(z, u - z, "rest", u, low, g))
    return Band(u, low, count, (u - low) / count, g), levels


def _least_slope(
    sorted_values: NDArray[np.float64],
    order: NDArray[np.intp],
    slopes: NDArray[np.float64],
    low: float,
    high: float,
) -> float | None:
    start = int(np.searchsorted(sorted_values, low + Z_TOL_MM, side="right"))
    stop = int(np.searchsorted(sorted_values, high - Z_TOL_MM, side="left"))
    if stop <= start:
        return None
    return float(slopes[order[start:stop]].min())
