"""The information form's algebra of readings (:mod:`supervisor.rcb.information`).

Over arrays and the tuples a belief holds, without the belief, so that
:mod:`supervisor.rcb.posterior` can move its readings' ``(J, h)`` with each update.
"""

from __future__ import annotations

import numpy as np

#: Eigenvalues of readings' information under this fraction of its largest are round-off.
EVIDENCE_FLOOR = 1e-9


def none_yet(size: int) -> tuple[tuple[tuple[float, ...], ...], tuple[float, ...]]:
    """``(J, h)`` of no reading, over ``β`` of ``size``: zeros, as tuples a belief holds."""
    return tuple((0.0,) * size for _ in range(size)), (0.0,) * size


def observed(
    readings: tuple[tuple[float, ...], ...] | None,
    vector: tuple[float, ...] | None,
    phi: np.ndarray,
    ln_y: float,
    noise: float,
    variance: float,
) -> tuple[tuple[tuple[float, ...], ...] | None, tuple[float, ...] | None]:
    """``(J, h)`` after a step ``variance`` of the intercept and a reading ``ln y`` at ``φ``.

    ``(None, None)`` for a belief that holds none (stored before they were kept).
    """
    if readings is None or vector is None:
        return None, None
    j, h = step(np.array(readings), np.array(vector), variance)
    j = j + np.outer(phi, phi) / noise**2
    h = h + phi * (ln_y / noise**2)
    return tuples(0.5 * (j + j.T), h)


def step(j: np.ndarray, h: np.ndarray, variance: float) -> tuple[np.ndarray, np.ndarray]:
    """``(J, h)`` after a step ``variance`` of the intercept (:mod:`supervisor.rcb.information`)."""
    if variance <= 0.0:
        return j, h
    column = j[:, 0].copy()
    denominator = 1.0 / variance + column[0]
    j = j - np.outer(column, column) / denominator
    return 0.5 * (j + j.T), h - column * (h[0] / denominator)


def tuples(j: np.ndarray, h: np.ndarray) -> tuple[tuple[tuple[float, ...], ...], tuple[float, ...]]:
    """``(J, h)`` as the tuples a belief holds."""
    return tuple(tuple(float(v) for v in row) for row in j), tuple(float(v) for v in h)


def positive_part(information: np.ndarray, vector: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Readings' information ``(J, h)`` with what is not evidence dropped.

    ``J = P − P₀`` (a posterior's precision less its prior's) is not positive semidefinite
    where the learner's forgetting (the random walk ``τ``, a change's discount) left less
    precision than the prior's: that direction carries no evidence. ``J`` is projected on the
    eigenvectors of positive eigenvalue (those under :data:`EVIDENCE_FLOOR` of the largest
    are round-off) and ``h`` with it. A belief stored before 2026-12-06 is read so; one
    that keeps its readings' ``(J, h)`` is not (:mod:`supervisor.rcb.information`).
    """
    j, h = positive_parts(information[np.newaxis], vector[np.newaxis])
    return j[0], h[0]


def positive_parts(information: np.ndarray, vector: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`positive_part` of a stack: ``information`` ``(N, k, k)``, ``vector`` ``(N, k)``.

    One call of numpy's stacked eigendecomposition for the stack, not one a belief.
    """
    j = 0.5 * (information + np.swapaxes(information, -1, -2))
    values, vectors = np.linalg.eigh(j)
    top = np.maximum(values.max(axis=-1, keepdims=True), 0.0)
    keep = values > EVIDENCE_FLOOR * top
    kept = vectors * keep[:, np.newaxis, :]  # the dropped eigenvectors' columns are 0
    kept_t = np.swapaxes(kept, -1, -2)
    projected = kept @ (kept_t @ vector[..., np.newaxis])
    return (kept * np.where(keep, values, 0.0)[:, np.newaxis, :]) @ kept_t, projected[..., 0]
