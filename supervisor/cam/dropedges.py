r"""Drop-cutter on the edges of the triangulated surface (:mod:`supervisor.cam.dropcutter`).

An edge from ``A`` to ``B`` rises with slope ``m`` along its horizontal direction. A cutter
whose axis stands at horizontal distance ``d`` from the edge's line, at ``t_f`` along it
(the foot of the axis), meets a vertical plane through the edge in the curve
``g(s) = h(sqrt(d² + s²))``, ``s`` along the edge from the foot. Its tip rises to

.. math:: z_A + m·t_f + \max_s \,(m·s − g(s))

with the contact at the maximising ``s``, which must lie on the edge:
``0 <= t_f + s <= L``. The maximum (the convex conjugate of ``g`` at ``m``) is

- ball of radius ``r``: ``ρ·sqrt(1 + m²) − r`` at ``s = ρ·m / sqrt(1 + m²)``,
  ``ρ = sqrt(r² − d²)``: the circle the ball shows in that plane;
- flat end mill of radius ``R``: ``w·|m|`` at ``s = ±w``, ``w = sqrt(R² − d²)``;
- bull nose: ``g`` is convex, so ``g'(s) = m`` is solved by bisection.

For each distance ``d`` on the pixel grid (one lattice line parallel to the edge family) the
contact offset ``s`` is known for every edge at once, and the axis positions with the contact
on the edge lie in an interval one edge long: at most two pixel centres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from supervisor.cam.cutter import Cutter

if TYPE_CHECKING:
    from collections.abc import Callable

#: Slack of the on-the-edge test, in pixels.
EPS_PX = 1e-9
#: Bisection steps of the bull nose's contact (the interval shrinks 2^-50).
BISECTIONS = 50


@dataclass(frozen=True)
class EdgeFamily:
    """Edges ``(row, col) → (row + dr, col + dc)`` and the pixel centres around them.

    A pixel centre is the edge's start plus ``i·U + k·W`` (``(dr, dc)`` steps): ``k`` picks
    the lattice line at distance ``|k|·delta`` from the edge's line, ``i`` the position
    along it, at ``i·tau + k·kappa`` from the start (all in pixels).
    """

    name: str
    step: tuple[int, int]  # the edge, (dr, dc)
    along: tuple[int, int]  # U
    across: tuple[int, int]  # W
    tau: float
    kappa: float
    delta: float


EDGE_FAMILIES = (
    EdgeFamily("along rows", (0, 1), (0, 1), (1, 0), 1.0, 0.0, 1.0),
    EdgeFamily("along columns", (1, 0), (1, 0), (0, 1), 1.0, 0.0, 1.0),
    EdgeFamily(
        "diagonal", (1, 1), (1, 1), (1, 0), math.sqrt(2), 1 / math.sqrt(2), 1 / math.sqrt(2)
    ),
)


def scatter_max(
    out: NDArray[np.float64],
    slot: NDArray[np.intp],
    row: NDArray[np.intp],
    col: NDArray[np.intp],
    value: NDArray[np.float64],
) -> None:
    """``out[slot[row], col] = max(out[...], value)`` where the row is wanted and inside."""
    rows, cols = slot.shape[0], out.shape[1]
    ok = (row >= 0) & (row < rows) & (col >= 0) & (col < cols)
    row, col, value = row[ok], col[ok], value[ok]
    where = slot[row]
    ok = where >= 0
    where, col, value = where[ok], col[ok], value[ok]
    higher = value > out[where, col]
    np.maximum.at(out, (where[higher], col[higher]), value[higher])


def raise_edges(
    z: NDArray[np.float64],
    cutter: Cutter,
    pixel_mm: float,
    slot: NDArray[np.intp],
    out: NDArray[np.float64],
    family: EdgeFamily,
) -> None:
    """Raise ``out`` where the cutter touches the interior of an edge of ``family``.

    ``slot[row]`` is the row of ``out`` holding the map's ``row`` (``-1``: not wanted).
    """
    p = pixel_mm
    dr, dc = family.step
    rows, cols = z.shape
    za = z[: rows - dr, : cols - dc].ravel()
    zb = z[dr:, dc:].ravel()
    r_idx, c_idx = np.mgrid[0 : rows - dr, 0 : cols - dc]
    row_a, col_a = r_idx.ravel(), c_idx.ravel()
    slope = (zb - za) / (family.tau * p)
    reach = math.floor(cutter.radius_mm / (family.delta * p) + 1e-9)
    # the wanted rows, padded so that a row just off the map reads "not wanted"
    pad = 2 * reach + 4
    wanted_row = np.concatenate((np.full(pad, -1), slot, np.full(pad, -1))) >= 0
    (ur, uc), (wr, wc) = family.along, family.across
    ridges = np.flatnonzero(_ridge(z, family).ravel())
    contact = _contact_function(cutter, slope)
    for k in range(-reach, reach + 1):
        d = abs(k) * family.delta * p
        if ur == 0:  # the pixel centres of this line are in one row: keep the wanted ones
            idx = ridges[wanted_row[row_a[ridges] + k * wr + pad]]
            if len(idx) == 0:
                continue
        else:
            idx = ridges
        s_mm, gain = contact(d, idx)
        low = (-s_mm / p - k * family.kappa) / family.tau
        first = np.ceil(low - EPS_PX).astype(np.intp)
        for di in (0, 1):
            i = first + di
            if ur == 0:
                sel = np.arange(len(idx))
            else:
                sel = np.flatnonzero(wanted_row[row_a[idx] + i * ur + (k * wr + pad)])
            edge = idx[sel]
            step = i[sel]
            along = step * family.tau + k * family.kappa  # the axis's foot from A [px]
            on = along + s_mm[sel] / p <= family.tau + EPS_PX
            edge, step, along = edge[on], step[on], along[on]
            tip = za[edge] + slope[edge] * (along * p) + gain[sel[on]]
            row = row_a[edge] + step * ur + k * wr
            col = col_a[edge] + step * uc + k * wc
            scatter_max(out, slot, row, col, tip)


def _ridge(z: NDArray[np.float64], family: EdgeFamily) -> NDArray[np.bool_]:
    """The edges where the surface folds down on both sides (and those on the map's rim).

    The two triangles on either side of an edge ``A → B`` have their third corners ``C1``,
    ``C2`` with ``A + B = C1 + C2`` on this grid, so the edge is a ridge when
    ``z(C1) + z(C2) < z(A) + z(B)``. A cutter, being convex, touches the interior of no other
    edge alone: at a valley or a flat fold it meets a facet first, which :func:`_facets`
    finds (``supervisor.cam.dropcutter``).
    """
    dr, dc = family.step
    rows, cols = z.shape
    a, b = z[: rows - dr, : cols - dc], z[dr:, dc:]
    pad = np.pad(z, 1, mode="constant", constant_values=np.nan)
    if family.step == (0, 1):  # C1 = (r + 1, c + 1), C2 = (r − 1, c)
        c1 = pad[2 : rows + 2, 2 : cols + 1]
        c2 = pad[0:rows, 1:cols]
    elif family.step == (1, 0):  # C1 = (r + 1, c + 1), C2 = (r, c − 1)
        c1 = pad[2 : rows + 1, 2 : cols + 2]
        c2 = pad[1:rows, 0:cols]
    else:  # the diagonal: C1 = (r, c + 1), C2 = (r + 1, c)
        c1, c2 = z[:-1, 1:], z[1:, :-1]
    folds = c1 + c2
    return np.asarray(~(folds >= a + b), dtype=np.bool_)  # NaN off the map: kept


def _contact_function(
    cutter: Cutter, slope: NDArray[np.float64]
) -> Callable[[float, NDArray[np.intp]], tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """``(d, edges) -> (s, max_s(m·s − g(s)))`` for those edges (module docstring) [mm]."""
    radius, corner = cutter.radius_mm, cutter.corner_radius_mm
    flat = radius - corner
    root = np.sqrt(1.0 + slope * slope)
    sine = slope / root

    def ball(d: float, idx: NDArray[np.intp]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        rho = math.sqrt(max(corner * corner - d * d, 0.0))
        return rho * sine[idx], rho * root[idx] - corner

    def flat_end(
        d: float, idx: NDArray[np.intp]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        w = math.sqrt(max(radius * radius - d * d, 0.0))
        m = slope[idx]
        return w * np.sign(m), w * np.abs(m)

    def bull(d: float, idx: NDArray[np.intp]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        w = math.sqrt(max(radius * radius - d * d, 0.0))
        m = slope[idx]
        low = np.full(m.shape, -w)
        high = np.full(m.shape, w)
        for _ in range(BISECTIONS):
            mid = 0.5 * (low + high)
            below = _bull_slope(mid, d, flat, corner) < m
            low = np.where(below, mid, low)
            high = np.where(below, high, mid)
        s = 0.5 * (low + high)
        dist = np.sqrt(d * d + s * s)
        return s, m * s - cutter.profile_mm(np.minimum(dist, radius))

    if cutter.kind == "ball":
        return ball
    if cutter.kind == "flat":
        return flat_end
    return bull


def _bull_slope(
    s: NDArray[np.float64], d: float, flat: float, corner: float
) -> NDArray[np.float64]:
    """``g'(s)`` of a bull nose: ``(s / D)·h'(D)``, ``D = sqrt(d² + s²)``."""
    dist = np.sqrt(d * d + s * s)
    u = np.clip(dist - flat, 0.0, corner)
    gap = np.sqrt(np.maximum(corner * corner - u * u, 1e-300))
    safe = np.where(dist > 0, dist, 1.0)
    return np.asarray(s / safe * u / gap, dtype=np.float64)
