"""Polylines to G1 lines and one-quadrant G2/G3 arcs (Borangiu et al., IFAC 2007, §3).

"Arcs can be in only one quadrant; if a generated arc spreads on more quadrants, the
conversion program will decompose the big arc in several smaller arcs, each of them in a
single quadrant. Arcs having the radius bigger than the superior limit of the CNC machine ...
are approximated by lines." Runs of at least :data:`MIN_POINTS` points that lie within
:data:`FIT_TOL_MM` of one circle, turn one way and stay in one quadrant of it become an arc.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: Largest distance of a polyline point from the fitted circle [mm].
FIT_TOL_MM = 2e-3
#: Largest gap between a polyline segment and the arc over it (the sagitta) [mm]: the
#: polyline's points lie on the circle, so the arc runs between the chords and the circle
#: they were cut from.
SAGITTA_TOL_MM = 1e-2
#: Fewest polyline points an arc replaces.
MIN_POINTS = 4
#: Most points tried in one arc.
MAX_POINTS = 400


@dataclass(frozen=True)
class Move:
    """A feed move to ``(x, y)``: a line, or an arc about ``centre`` (``ccw``: G3)."""

    x: float
    y: float
    centre: tuple[float, float] | None = None
    ccw: bool = False


def _circle(
    a: NDArray[np.float64], b: NDArray[np.float64], c: NDArray[np.float64]
) -> tuple[float, float, float] | None:
    d = 2 * (a[0] * (b[1] - c[1]) + b[0] * (c[1] - a[1]) + c[0] * (a[1] - b[1]))
    if abs(d) < 1e-12:
        return None
    sa, sb, sc = a[0] * a[0] + a[1] * a[1], b[0] * b[0] + b[1] * b[1], c[0] * c[0] + c[1] * c[1]
    ux = (sa * (b[1] - c[1]) + sb * (c[1] - a[1]) + sc * (a[1] - b[1])) / d
    uy = (sa * (c[0] - b[0]) + sb * (a[0] - c[0]) + sc * (b[0] - a[0])) / d
    return float(ux), float(uy), float(math.hypot(a[0] - ux, a[1] - uy))


def _quadrant(dx: NDArray[np.float64], dy: NDArray[np.float64]) -> NDArray[np.int_]:
    return np.asarray(np.floor(np.arctan2(dy, dx) / (math.pi / 2)).astype(int) % 4)


def _may_fit(points: NDArray[np.float64], max_radius_mm: float) -> bool:
    """A quick test on the first three points in plain floats: most polylines fail here."""
    (ax, ay), (bx, by), (cx, cy) = points[0].tolist(), points[1].tolist(), points[2].tolist()
    d = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    if abs(d) < 1e-12:
        return False
    sa, sb, sc = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
    ux = (sa * (by - cy) + sb * (cy - ay) + sc * (ay - by)) / d
    uy = (sa * (cx - bx) + sb * (ax - cx) + sc * (bx - ax)) / d
    r = math.hypot(ax - ux, ay - uy)
    half = max(math.hypot(bx - ax, by - ay), math.hypot(cx - bx, cy - by)) / 2
    return (
        1e-3 <= r <= max_radius_mm
        and half < r
        and r - math.sqrt(r * r - half * half) <= SAGITTA_TOL_MM
    )


def _fits(points: NDArray[np.float64], max_radius_mm: float) -> tuple[float, float, bool] | None:
    """The arc through ``points`` if it is one (module docstring), else None."""
    if not _may_fit(points, max_radius_mm):
        return None
    circle = _circle(points[0], points[len(points) // 2], points[-1])
    if circle is None:
        return None
    cx, cy, r = circle
    if r > max_radius_mm or r < 1e-3:
        return None
    seg = np.diff(points, axis=0)
    half = float(np.hypot(seg[:, 0], seg[:, 1]).max()) / 2
    if half >= r or r - math.sqrt(r * r - half * half) > SAGITTA_TOL_MM:
        return None
    dx, dy = points[:, 0] - cx, points[:, 1] - cy
    if np.abs(np.hypot(dx, dy) - r).max() > FIT_TOL_MM:
        return None
    cross = dx[:-1] * seg[:, 1] - dy[:-1] * seg[:, 0]
    if not (np.all(cross > 0) or np.all(cross < 0)):
        return None
    # one quadrant: every point, the ends included, in the closed quadrant of the middle one
    mid = len(points) // 2
    q = int(_quadrant(dx[mid : mid + 1], dy[mid : mid + 1])[0])
    angle = np.arctan2(dy, dx) - q * math.pi / 2
    angle = (angle + math.pi) % (2 * math.pi) - math.pi
    if np.any(angle < -1e-9) or np.any(angle > math.pi / 2 + 1e-9):
        return None
    return cx, cy, bool(cross[0] > 0)


#: Run lengths (points − 1) whose fits :func:`fit_tables` works out for every start at once:
#: the first three the doubling in :func:`to_moves` tries.
TABLED = (MIN_POINTS - 1, 2 * (MIN_POINTS - 1), 4 * (MIN_POINTS - 1))
#: A run's fit for every start: whether it fits, and the centre and direction where it does.
Table = dict[
    int, tuple[NDArray[np.bool_], NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]
]


def fit_tables(paths: list[NDArray[np.float64]], max_radius_mm: float) -> list[Table]:
    """:func:`_fits` of every run of :data:`TABLED` lengths of every path, in one go.

    The same tests in the same order as :func:`_fits`, on arrays over all the paths
    joined (a run that would cross from one path into the next is marked as no fit), so
    the cost of a test is paid once for a level, not once per run.
    """
    if not paths:
        return []
    joined = np.vstack(paths)
    starts = np.cumsum([0] + [len(q) for q in paths])
    path_end = np.repeat(starts[1:], [len(q) for q in paths])  # one past each point's path
    columns = {}
    for k in TABLED:
        length = k + 1
        count = len(joined) - length + 1
        if count <= 0:
            empty = np.zeros(0)
            columns[k] = (np.zeros(0, dtype=bool), empty, empty, np.zeros(0, dtype=bool))
            continue
        w = np.lib.stride_tricks.sliding_window_view(joined, (length, 2))[:, 0]
        ok = np.arange(count) + length <= path_end[:count]
        columns[k] = _fits_all(w, ok, max_radius_mm)
    out: list[Table] = []
    for a, b in zip(starts[:-1], starts[1:], strict=True):
        out.append({k: tuple(c[a:b] for c in col) for k, col in columns.items()})  # type: ignore[misc]
    return out


def _fits_all(
    w: NDArray[np.float64], ok: NDArray[np.bool_], max_radius_mm: float
) -> tuple[NDArray[np.bool_], NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """:func:`_fits` of each run ``w[i]`` (``(count, L, 2)``) where ``ok``, on arrays."""
    length = w.shape[1]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for a, b, c, first in ((0, 1, 2, True), (0, length // 2, length - 1, False)):
            ax, ay, bx, by = w[:, a, 0], w[:, a, 1], w[:, b, 0], w[:, b, 1]
            cx, cy = w[:, c, 0], w[:, c, 1]
            d = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
            ok &= np.abs(d) >= 1e-12
            sa, sb, sc = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
            ux = (sa * (by - cy) + sb * (cy - ay) + sc * (ay - by)) / d
            uy = (sa * (cx - bx) + sb * (ax - cx) + sc * (bx - ax)) / d
            r = np.hypot(ax - ux, ay - uy)
            if first:
                half = np.maximum(np.hypot(bx - ax, by - ay), np.hypot(cx - bx, cy - by)) / 2
            else:
                seg = np.diff(w, axis=1)
                half = np.hypot(seg[..., 0], seg[..., 1]).max(axis=1) / 2
            ok &= (r >= 1e-3) & (r <= max_radius_mm) & (half < r)
            ok &= r - np.sqrt(np.clip(r * r - half * half, 0.0, None)) <= SAGITTA_TOL_MM
        dx, dy = w[..., 0] - ux[:, None], w[..., 1] - uy[:, None]
        ok &= np.abs(np.hypot(dx, dy) - r[:, None]).max(axis=1) <= FIT_TOL_MM
        cross = dx[:, :-1] * seg[..., 1] - dy[:, :-1] * seg[..., 0]
        ok &= np.all(cross > 0, axis=1) | np.all(cross < 0, axis=1)
        mid = length // 2
        q = _quadrant(dx[:, mid], dy[:, mid])
        angle = np.arctan2(dy, dx) - q[:, None] * (math.pi / 2)
        angle = (angle + math.pi) % (2 * math.pi) - math.pi
        ok &= ~(np.any(angle < -1e-9, axis=1) | np.any(angle > math.pi / 2 + 1e-9, axis=1))
    return ok, ux, uy, cross[:, 0] > 0


def to_moves(
    points: NDArray[np.float64], max_radius_mm: float, table: Table | None = None
) -> list[Move]:
    """The moves that follow ``points[1:]`` from ``points[0]``.

    From each point the arc is grown by doubling its length while it fits (the longest of
    those is taken: a bisection towards the first misfit cost as much again for little).
    ``table``: the path's :func:`fit_tables` entry, the fits of the first lengths tried.
    """
    known = table or {}
    moves: list[Move] = []
    i, n = 0, len(points)
    while i < n - 1:
        j = i + MIN_POINTS - 1
        best: tuple[int, tuple[float, float, bool]] | None = None
        while j < n and j - i < MAX_POINTS:
            row = known.get(j - i)
            if row is None:
                fit = _fits(points[i : j + 1], max_radius_mm)
            else:
                fit = (float(row[1][i]), float(row[2][i]), bool(row[3][i])) if row[0][i] else None
            if fit is None:
                break
            best = (j, fit)
            j = i + 2 * (j - i)
            if j >= n > best[0] + 1 and n - 1 - i < MAX_POINTS:
                j = n - 1  # the rest of the polyline, once
        if best is None:
            moves.append(Move(float(points[i + 1, 0]), float(points[i + 1, 1])))
            i += 1
            continue
        j, (cx, cy, ccw) = best
        moves.append(Move(float(points[j, 0]), float(points[j, 1]), (cx, cy), ccw))
        i = j
    return moves
