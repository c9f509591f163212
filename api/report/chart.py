"""What a plot shows, as data: panels of marks over the parts, drawn by :mod:`api.report.svg`.

A :class:`Chart` is a title, an x label and panels stacked on one shared part axis; a
:class:`Panel` is a y label and its :class:`Mark` s (a line, steps, points, a shaded band,
error bars, a horizontal line), each with the label its legend entry shows. The ``*_figure``
functions of :mod:`api.report.plots` build them; nothing here draws or formats.

:func:`nice_ticks` chooses the tick values of an axis: round steps of 1, 2, 2.5 or 5 times a
power of ten, after Heckbert's "nice numbers for graph labels" (Graphics Gems, 1990), as
matplotlib's ``MaxNLocator`` does, without importing matplotlib (about 0.3 s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from api.report.series import Array

#: How a mark is drawn: ``line`` (straight segments), ``steps`` (a step per part, centred on
#: it), ``points`` (a marker per value), ``band`` (shaded between ``y`` and ``y2``, stepped),
#: ``bars`` (a vertical bar from ``y`` to ``y2`` per value), ``ranges`` (a thick bar from ``y``
#: to ``y2`` per group of parts, never shorter than a dot: the lowest to the highest of many
#: parts), ``hline`` (across the panel at ``y[0]``), ``vlines`` (top to bottom of the panel at
#: each ``x``: an event at a part, its ``y`` unused).
MarkKind = Literal["line", "steps", "points", "band", "bars", "ranges", "hline", "vlines"]
#: The shape of a point marker.
Marker = Literal["dot", "open", "cross", "triangle", "diamond"]
#: The round steps of an axis, per power of ten.
NICE_STEPS = (1.0, 2.0, 2.5, 5.0, 10.0)


@dataclass(frozen=True)
class Mark:
    """One thing drawn in a panel, with its legend label (``None``: not in the legend).

    Parameters
    ----------
    kind : MarkKind
        How it is drawn.
    x, y : ndarray
        Part numbers and values (NaN: nothing drawn there).
    y2 : ndarray, optional
        The other edge of a ``band``, ``bars`` or ``ranges``.
    color : str
        An SVG colour.
    label : str, optional
        Its legend entry.
    marker : Marker
        The shape of ``points``.
    dashed, dotted : bool
        The dash pattern of a ``line``, ``steps`` or ``hline``.
    gid : str, optional
        An id for the drawn element (prefixed with the SVG's ``id_prefix``).
    """

    kind: MarkKind
    x: Array
    y: Array
    color: str
    label: str | None = None
    y2: Array | None = None
    marker: Marker = "dot"
    dashed: bool = False
    dotted: bool = False
    gid: str | None = None


@dataclass(frozen=True)
class Panel:
    """One row of a chart: its y label, its marks, and whether its y axis starts at zero."""

    ylabel: str
    marks: tuple[Mark, ...]
    from_zero: bool = False


@dataclass(frozen=True)
class Chart:
    """Panels stacked on one part axis, with a title (may be empty) and the x label."""

    title: str
    xlabel: str
    panels: tuple[Panel, ...]


def nice_ticks(low: float, high: float, most: int = 6) -> list[float]:
    """About ``most`` round tick values covering ``[low, high]`` (a widened range if equal).

    >>> nice_ticks(0.0123, 0.0571)
    [0.01, 0.02, 0.03, 0.04, 0.05, 0.06]
    """
    if not (math.isfinite(low) and math.isfinite(high)):
        return [0.0, 1.0]
    if high <= low:
        pad = abs(low) * 0.05 or 1.0
        low, high = low - pad, high + pad
    raw = (high - low) / max(most - 1, 1)
    power = 10.0 ** math.floor(math.log10(raw))
    step = next(s * power for s in NICE_STEPS if s * power >= raw * (1 - 1e-9))
    first = math.floor(low / step + 1e-9) * step
    count = math.ceil((high - first) / step - 1e-9) + 1
    ticks = first + step * np.arange(count)
    digits = max(0, -math.floor(math.log10(step)) + 2)
    return [round(float(t), digits) + 0.0 for t in ticks]
