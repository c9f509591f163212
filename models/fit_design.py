"""Checks of a power-law fit's data: numeric columns, logarithms, a design that can be fitted.

Every error names the column (by its label) and, where it can, the row and the value. A free
log column must vary, and the free log columns must not be collinear: the least-to-largest
singular value ratio of the centred, column-scaled log design is at least
:data:`MIN_SINGULAR_RATIO` (Draper & Smith, Applied Regression Analysis, 3rd ed., Ch. 5).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import numpy.typing as npt

from models.errors import InputError

#: Smallest ratio of the least to the largest singular value of the centred, column-scaled log
#: design; below it the free columns are taken as collinear (about ``sqrt(machine epsilon)``:
#: half the significant digits of the estimates would be lost).
MIN_SINGULAR_RATIO = 1e-8

#: A log column whose spread is below this (times its magnitude, at least 1) is constant.
CONSTANT_RTOL = 1e-12

FloatArray = npt.NDArray[np.float64]


def vector(values: Sequence[float] | FloatArray, label: str) -> FloatArray:
    """A 1-D float array, or an InputError naming ``label``."""
    try:
        array = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InputError(label, values, f"must be a list of numbers ({err})") from None
    if array.ndim != 1:
        raise InputError(label, f"shape {array.shape}", "must be a one-dimensional column")
    return array


def check_positive(values: FloatArray, label: str, rows: Sequence[object]) -> None:
    """Refuse the first value that has no logarithm (not finite, zero or negative)."""
    bad = np.flatnonzero(~(np.isfinite(values) & (values > 0)))
    if bad.size:
        i = int(bad[0])
        value = float(values[i])
        reason = (
            "must be a finite number"
            if not math.isfinite(value)
            else "must be greater than 0 (the power law is fitted on logarithms)"
        )
        raise InputError(f"{label}[{rows[i]}]", value, reason)


def check_design(
    free: list[str], values: list[FloatArray], logs: list[FloatArray], labels: Mapping[str, str]
) -> None:
    """Refuse constant and collinear free log columns, naming the column."""
    for name, raw, column in zip(free, values, logs, strict=True):
        spread = float(np.ptp(column))
        if spread <= CONSTANT_RTOL * max(1.0, float(np.max(np.abs(column)))):
            raise InputError(
                labels.get(name, name),
                float(raw[0]),
                f"constant column: every point has this {name}, so its exponent cannot be "
                "fitted; fix the exponent or leave the variable out",
            )
    if len(free) < 2:
        return
    centred = np.column_stack([c - float(np.mean(c)) for c in logs])
    scaled = centred / np.linalg.norm(centred, axis=0)
    _, singular, vt = np.linalg.svd(scaled, full_matrices=False)
    ratio = float(singular[-1] / singular[0])
    if ratio >= MIN_SINGULAR_RATIO:
        return
    null = np.abs(vt[-1])
    involved = [i for i in range(len(free)) if null[i] > 0.01 * float(np.max(null))]
    last = involved[-1]
    others = involved[:-1]
    name = free[last]
    basis = np.column_stack([np.ones(logs[last].size), *(logs[i] for i in others)])
    coef, *_ = np.linalg.lstsq(basis, logs[last], rcond=None)
    relation = f"ln {name} = {_tidy(float(coef[0])):.4g}"
    for c, i in zip(coef[1:], others, strict=True):
        c = _tidy(float(c))
        relation += f" {'-' if c < 0 else '+'} {abs(c):.4g}·ln {free[i]}"
    with_names = ", ".join(_named(free[i], labels) for i in others)
    raise InputError(
        labels.get(name, name),
        relation,
        f"collinear with {with_names} (least/largest singular value of the scaled log design "
        f"{ratio:.2g} < {MIN_SINGULAR_RATIO:g}): their exponents cannot be told apart; fix one "
        "exponent or leave a variable out",
    )


def _named(name: str, labels: Mapping[str, str]) -> str:
    """``label (name)``, or ``name`` when it has no other label."""
    label = labels.get(name, name)
    return name if label == name else f"{label} ({name})"


def _tidy(value: float) -> float:
    """``value`` with rounding noise below 1e-9 shown as 0."""
    return 0.0 if abs(value) < 1e-9 else value
