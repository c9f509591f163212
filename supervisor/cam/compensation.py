r"""Cutter compensation as grey-scale dilation (Borangiu et al., IFAC 2007, §3 and Fig. 3).

"At every location in the XY plane (i.e. any pixel in the image) one has to compute the depth
which should be reached by the milling cutter, in order to be tangent to the surface. The
shape of the milling cutter is modelled as a greyscale image, using the same scale factors as
for the surface to be milled." The tip height at ``x`` is

.. math:: c(x) = \max_{|y - x| \le R} \; s(y) - h(|x - y|)

with ``h`` the cutter's profile (:meth:`supervisor.cam.cutter.Cutter.profile_mm`): the
grey-scale dilation of the height map ``s`` by the structuring function ``−h``
(:func:`scipy.ndimage.grey_dilation`). Outside the map there is no material.

This is the cutter against the pixel centres only: the vertices of the triangulated surface.
The finishing drops the cutter on its edges and facets too (:mod:`supervisor.cam.dropcutter`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from supervisor.cam.cutter import Cutter

#: Height given to the world outside the map: far below anything (no material there).
_OUTSIDE_MM = -1.0e9


def compensate(
    height_mm: NDArray[np.float64], cutter: Cutter, pixel_mm: float
) -> NDArray[np.float64]:
    """The surface the cutter's tip follows so that the cutter stays tangent to ``height_mm``.

    Parameters
    ----------
    height_mm : ndarray
        The model's heights on the pixel grid [mm].
    cutter : Cutter
        The cutter.
    pixel_mm : float
        Pixel size [mm].

    Returns
    -------
    ndarray
        Tip heights [mm], same shape.
    """
    footprint, structure = cutter.kernel(pixel_mm)
    out = ndimage.grey_dilation(
        height_mm, footprint=footprint, structure=structure, mode="constant", cval=_OUTSIDE_MM
    )
    return np.asarray(out, dtype=np.float64)


def offset_surface(
    height_mm: NDArray[np.float64], allowance_mm: float, pixel_mm: float
) -> NDArray[np.float64]:
    """The model grown by a stock allowance in 3D: the dilation by a ball of radius ``a``.

    ``s_a(x) = max_{|y−x|<=a} s(y) + sqrt(a² − |x−y|²)``: a point at or above ``s_a`` is at
    least ``a`` from the model, so a flat end mill whose bottom stays on or above ``s_a``
    and whose side stays outside the contour of ``{s_a > z}`` leaves the allowance ``a``
    everywhere, a convex edge included (an offset in x, y and z separately would leave
    ``a·√2`` there).
    """
    if allowance_mm <= 0:
        return np.asarray(height_mm, dtype=np.float64)
    reach = int(np.floor(allowance_mm / pixel_mm + 1e-9))
    yy, xx = np.mgrid[-reach : reach + 1, -reach : reach + 1]
    d = np.hypot(yy, xx) * pixel_mm
    footprint = d <= allowance_mm + 1e-9
    structure = np.where(footprint, np.sqrt(np.clip(allowance_mm**2 - d**2, 0.0, None)), 0.0)
    out = ndimage.grey_dilation(
        height_mm, footprint=footprint, structure=structure, mode="constant", cval=_OUTSIDE_MM
    )
    return np.asarray(out, dtype=np.float64)


def compensate_rows(
    height_mm: NDArray[np.float64], cutter: Cutter, pixel_mm: float, rows: NDArray[np.intp]
) -> NDArray[np.float64]:
    """:func:`compensate` on the given rows only, shape ``(len(rows), cols)``.

    The same dilation taken one kernel row at a time: for each row offset ``dy`` of the
    cutter's footprint, a 1-D dilation along X of the map's rows ``rows + dy`` by that row of
    the structure, and the largest over ``dy``. What iso-parametric lines along X need (a
    line every few pixels), at that fraction of the full map's cost.
    """
    footprint, structure = cutter.kernel(pixel_mm)
    reach = footprint.shape[0] // 2
    padded = np.pad(height_mm, ((reach, reach), (0, 0)), constant_values=_OUTSIDE_MM)
    out = np.full((len(rows), height_mm.shape[1]), _OUTSIDE_MM)
    for k in range(footprint.shape[0]):
        line = footprint[k : k + 1]
        if not line.any():
            continue
        source = padded[np.asarray(rows) + k]
        part = ndimage.grey_dilation(
            source,
            footprint=line,
            structure=structure[k : k + 1],
            mode="constant",
            cval=_OUTSIDE_MM,
        )
        np.maximum(out, part, out=out)
    return out
