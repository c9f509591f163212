r"""Drop-cutter on the triangulated surface through the pixel centres.

The surface convention. A height map is the triangulated surface through its pixel centres,
as OpenCAMLib and CAM systems read it: pixel ``(row, col)`` is the vertex
``(col·p, (rows − 1 − row)·p, z)``, and each square of four neighbouring centres is split
into two triangles along the diagonal from ``(row, col)`` to ``(row + 1, col + 1)``. Outside
the outermost centres there is no material.

The tip height of a cutter whose axis stands at ``x`` and that touches this surface from
above is

.. math:: c(x) = \max_{y \in S} \; z(y) - h(|x - y|)

over the surface's points ``y`` within the cutter's radius, ``h`` the cutter's profile
(:meth:`supervisor.cam.cutter.Cutter.profile_mm`). The surface is made of vertices, edges and
facets, and the cutter touches one of them (OpenCAMLib's ``dropCutter``: vertex, facet, edge
tests). Here each test is turned round: for each element, the cutter positions on the pixel
grid at which the cutter touches that element's interior are found (a facet's contact lies
at a fixed offset from the axis, an edge's at a fixed offset along it for each distance
from it), so the work grows with the elements times the grid positions near each, all on
arrays:

- vertices: the grey-scale dilation of the map
  (:func:`supervisor.cam.compensation.compensate_rows`);
- facets (:func:`_facets`): for a plane with unit normal ``n`` rising along ``u``, a cutter
  of radius ``R`` and corner radius ``r`` touches it at ``a·u − r·n_xy`` from its axis
  (``a = R − r``; ``0`` on a level plane), its tip at ``z(P) + r·n_z − r``;
- edges (:mod:`supervisor.cam.dropedges`).

References
----------
.. [1] A. Wallin, OpenCAMLib, ``MillingCutter::dropCutter`` (vertex, facet and edge drop).
.. [2] Borangiu et al., IFAC 2007, §3 and Fig. 3 (the compensation on the pixel grid).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from supervisor.cam.compensation import compensate_rows
from supervisor.cam.cutter import Cutter
from supervisor.cam.dropedges import EDGE_FAMILIES, raise_edges, scatter_max

#: Slack of the inside tests, in pixels (a contact on a shared edge belongs to both sides).
EPS_PX = 1e-9


def drop_rows(
    height_mm: NDArray[np.float64], cutter: Cutter, pixel_mm: float, rows: NDArray[np.intp]
) -> NDArray[np.float64]:
    """Tip heights on the triangulated surface at every pixel centre of ``rows`` [mm].

    Parameters
    ----------
    height_mm : ndarray
        The map's heights at the pixel centres [mm], shape ``(rows, cols)``.
    cutter : Cutter
        The cutter.
    pixel_mm : float
        Pixel size [mm].
    rows : ndarray of int
        The rows whose pixel centres carry the cutter's axis.

    Returns
    -------
    ndarray
        Tip heights [mm], shape ``(len(rows), cols)`` (module docstring).
    """
    z = np.asarray(height_mm, dtype=np.float64)
    rows = np.asarray(rows, dtype=np.intp)
    out = compensate_rows(z, cutter, pixel_mm, rows)
    slot = np.full(z.shape[0], -1, dtype=np.intp)
    slot[rows] = np.arange(len(rows))
    _facets(z, cutter, pixel_mm, slot, out)
    for family in EDGE_FAMILIES:
        raise_edges(z, cutter, pixel_mm, slot, out, family)
    return out


def drop_map(
    height_mm: NDArray[np.float64], cutter: Cutter, pixel_mm: float
) -> NDArray[np.float64]:
    """:func:`drop_rows` at every pixel centre of the map [mm]."""
    return drop_rows(height_mm, cutter, pixel_mm, np.arange(height_mm.shape[0]))


def _facets(
    z: NDArray[np.float64],
    cutter: Cutter,
    pixel_mm: float,
    slot: NDArray[np.intp],
    out: NDArray[np.float64],
) -> None:
    """Raise ``out`` where the cutter touches a facet's interior (module docstring).

    Local coordinates of a square, in pixels: ``s`` along the columns, ``t`` along the rows
    (downwards). Triangle "upper" ``(0,0), (1,0), (1,1)``: ``0 <= t <= s <= 1``; triangle
    "lower" ``(0,0), (1,1), (0,1)``: ``0 <= s <= t <= 1``. The plane is
    ``z00 + (gx·s + gy·t)·p`` with ``gx``, ``gy`` its slopes along the columns and the rows.
    """
    p = pixel_mm
    z00, z01, z11, z10 = z[:-1, :-1], z[:-1, 1:], z[1:, 1:], z[1:, :-1]
    r_idx, c_idx = np.mgrid[0 : z.shape[0] - 1, 0 : z.shape[1] - 1]
    row0, col0, z0 = r_idx.ravel(), c_idx.ravel(), z00.ravel()
    upper = ((z01 - z00).ravel() / p, (z11 - z01).ravel() / p)
    lower = ((z11 - z10).ravel() / p, (z10 - z00).ravel() / p)
    a = cutter.radius_mm - cutter.corner_radius_mm
    r = cutter.corner_radius_mm
    for (gx, gy), is_upper in ((upper, True), (lower, False)):
        norm = np.sqrt(1.0 + gx * gx + gy * gy)
        rise = np.hypot(gx, gy)
        level = rise == 0
        safe = np.where(level, 1.0, rise)
        ox = (np.where(level, 0.0, a * gx / safe) + r * gx / norm) / p  # axis → contact, px
        oy = (np.where(level, 0.0, a * gy / safe) + r * gy / norm) / p
        lift = r / norm - r
        first_row = np.ceil(row0 - oy - EPS_PX).astype(np.intp)
        first_col = np.ceil(col0 - ox - EPS_PX).astype(np.intp)
        for dr in (0, 1):
            cl_row = first_row + dr
            inside_map = (cl_row >= 0) & (cl_row < z.shape[0])
            wanted = np.zeros_like(inside_map)
            wanted[inside_map] = slot[cl_row[inside_map]] >= 0
            idx = np.flatnonzero(wanted)
            at_row = cl_row[idx]
            t = at_row + oy[idx] - row0[idx]
            for dc in (0, 1):
                cl_col = first_col[idx] + dc
                s = cl_col + ox[idx] - col0[idx]
                if is_upper:
                    inside = (t >= -EPS_PX) & (t <= s + EPS_PX) & (s <= 1 + EPS_PX)
                else:
                    inside = (s >= -EPS_PX) & (s <= t + EPS_PX) & (t <= 1 + EPS_PX)
                k = idx[inside]
                tip = z0[k] + (gx[k] * s[inside] + gy[k] * t[inside]) * p + lift[k]
                scatter_max(out, slot, at_row[inside], cl_col[inside], tip)
