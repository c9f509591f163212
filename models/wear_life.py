r"""Tool life from flank-wear series: the time at which a tool's wear first reaches a limit.

A tool's life ends when its flank wear VB reaches a criterion (ISO 3685: 0.3 mm for uniform
flank wear of carbide). Wear is measured now and then while the tool cuts; the life is taken
where the series first reaches the limit, linear between the two measurements around it:

.. math::

    T = t_{j-1} + (VB_{lim} - VB_{j-1}) \frac{t_j - t_{j-1}}{VB_j - VB_{j-1}}

with :math:`j` the first measurement at or above :math:`VB_{lim}` in time order (:math:`T = t_0`
when the first already is). Times without a measurement (NaN wear) are skipped; a series that
never reaches the limit has no life (it is censored, not a failure at its last time).

References
----------
.. [1] ISO 3685:1993, Tool-life testing with single-point turning tools, §7.2 (VB = 0.3 mm).
.. [2] Goebel & Agogino, "Milling Data Set", NASA Ames Prognostics Data Repository (2007).
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Sequence

import numpy as np
import numpy.typing as npt

from models.errors import InputError

#: Numbers as a sequence or an array.
Numbers = Sequence[float] | npt.NDArray[np.float64]


def life_at_wear(times: Numbers, wear_mm: Numbers, limit_mm: float) -> float | None:
    """The time at which one tool's wear first reaches ``limit_mm``; None if it never does.

    Parameters
    ----------
    times : sequence of float
        When each wear measurement was taken (any unit; the life is in the same) [time].
    wear_mm : sequence of float
        Flank wear at those times, NaN where none was measured [mm].
    limit_mm : float
        The wear that ends the tool's life, > 0 [mm].
    """
    if not (math.isfinite(limit_mm) and limit_mm > 0):
        raise InputError("limit_mm", limit_mm, "the wear limit must be a finite number > 0")
    t = np.asarray(times, dtype=float)
    vb = np.asarray(wear_mm, dtype=float)
    if t.shape != vb.shape or t.ndim != 1:
        raise InputError("wear_mm", len(vb), f"needs one wear per time ({len(t)} times)")
    measured = ~np.isnan(vb)
    t, vb = t[measured], vb[measured]
    order = np.argsort(t, kind="stable")
    t, vb = t[order], vb[order]
    above = np.flatnonzero(vb >= limit_mm)
    if above.size == 0:
        return None
    j = int(above[0])
    if j == 0:
        return float(t[0])
    return float(t[j - 1] + (limit_mm - vb[j - 1]) * (t[j] - t[j - 1]) / (vb[j] - vb[j - 1]))


def series_lives(
    series: Sequence[Hashable],
    times: Numbers,
    wear_mm: Numbers,
    limit_mm: float,
) -> tuple[dict[Hashable, float], list[Hashable]]:
    """Per tool (``series`` labels its rows), the life to ``limit_mm`` (:func:`life_at_wear`).

    Returns the lives of the series that reach the limit and the series that never do, each
    in the order the series first appear.
    """
    rows: dict[Hashable, list[int]] = {}
    for i, label in enumerate(series):
        rows.setdefault(label, []).append(i)
    t = np.asarray(times, dtype=float)
    vb = np.asarray(wear_mm, dtype=float)
    lives: dict[Hashable, float] = {}
    never: list[Hashable] = []
    for label, index in rows.items():
        life = life_at_wear(t[index], vb[index], limit_mm)
        if life is None:
            never.append(label)
        else:
            lives[label] = life
    return lives, never
