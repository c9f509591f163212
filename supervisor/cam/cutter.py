"""Cutter shapes: flat end mill, ball end mill, bull nose (Borangiu et al., IFAC 2007, §3).

A cutter is described by its profile: the height of its lower surface above its tip at a
radial distance ``d`` from its axis. The compensation (:mod:`supervisor.cam.compensation`)
and the verification (:mod:`supervisor.cam.verify`) both use it, sampled on the pixel grid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from models.errors import InputError

CutterKind = Literal["flat", "ball", "bull"]
#: Cutter kinds and how each is written on the command line.
KINDS: dict[str, str] = {
    "flat": "flat:D (flat end mill, diameter D mm)",
    "ball": "ball:D (ball end mill, diameter D mm)",
    "bull": "bull:D:R (bull nose, diameter D mm, corner radius R mm)",
}


@dataclass(frozen=True)
class Cutter:
    """A milling cutter's shape.

    Parameters
    ----------
    kind : {"flat", "ball", "bull"}
        Flat end mill, ball end mill, or flat end mill with a corner radius (bull nose).
    diameter_mm : float
        Cutting diameter [mm].
    corner_radius_mm : float
        Corner radius [mm]: 0 for flat, ``D/2`` for ball, ``0 < r < D/2`` for bull nose.
    """

    kind: CutterKind
    diameter_mm: float
    corner_radius_mm: float

    @property
    def radius_mm(self) -> float:
        """Half the diameter [mm]."""
        return self.diameter_mm / 2

    def describe(self) -> str:
        """``flat:10``, ``ball:6``, ``bull:10:2``."""
        if self.kind == "bull":
            return f"bull:{self.diameter_mm:g}:{self.corner_radius_mm:g}"
        return f"{self.kind}:{self.diameter_mm:g}"

    def profile_mm(self, distance_mm: NDArray[np.float64]) -> NDArray[np.float64]:
        """Height of the cutter's lower surface above its tip at radial distance ``d`` [mm].

        ``0`` on the flat bottom (``d <= R − r``), ``r − sqrt(r² − (d − (R − r))²)`` on the
        corner of radius ``r``, ``+inf`` beyond the radius ``R``.
        """
        d = np.asarray(distance_mm, dtype=np.float64)
        flat = self.radius_mm - self.corner_radius_mm
        r = self.corner_radius_mm
        out = np.full(d.shape, np.inf)
        inside = d <= self.radius_mm + 1e-12
        out[inside & (d <= flat)] = 0.0
        corner = inside & (d > flat)
        if r > 0:
            u = np.minimum(d[corner] - flat, r)
            out[corner] = r - np.sqrt(r * r - u * u)
        return out

    def kernel(self, pixel_mm: float) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
        """The cutter as a grey-scale structuring element on the pixel grid.

        Returns the footprint (pixels within the radius) and, on it, ``−profile`` [mm]: the
        structure of :func:`scipy.ndimage.grey_dilation` (Borangiu Fig. 3: the greyscale
        representation of the cutter shape).
        """
        reach = int(math.floor(self.radius_mm / pixel_mm + 1e-9))
        yy, xx = np.mgrid[-reach : reach + 1, -reach : reach + 1]
        d = np.hypot(yy, xx) * pixel_mm
        footprint = d <= self.radius_mm + 1e-9
        structure = np.where(footprint, -self.profile_mm(np.minimum(d, self.radius_mm)), 0.0)
        return footprint, structure


def parse_cutter(text: str, field: str = "tool") -> Cutter:
    """``flat:10``, ``ball:6`` or ``bull:10:2`` (diameter and corner radius in mm)."""
    parts = text.strip().split(":")
    kind = parts[0].lower()
    if kind not in KINDS:
        raise InputError(field, text, "must be " + ", ".join(KINDS.values()))
    want = 3 if kind == "bull" else 2
    if len(parts) != want:
        raise InputError(field, text, f"must be {KINDS[kind]}")
    try:
        numbers = [float(p) for p in parts[1:]]
    except ValueError:
        raise InputError(field, text, f"must be {KINDS[kind]}") from None
    diameter = numbers[0]
    if not (math.isfinite(diameter) and 0.05 <= diameter <= 200):
        raise InputError(field, text, "the diameter must be 0.05 to 200 mm")
    if kind == "flat":
        return Cutter("flat", diameter, 0.0)
    if kind == "ball":
        return Cutter("ball", diameter, diameter / 2)
    corner = numbers[1]
    if not (math.isfinite(corner) and 0 < corner < diameter / 2):
        raise InputError(field, text, "the corner radius must be above 0 and below D/2")
    return Cutter("bull", diameter, corner)
