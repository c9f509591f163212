r"""The points of a power-law fit (:func:`models.fit.fit_power_law`), checked and on the log scale.

Exponents that are fixed move to the left-hand side, and the free exponents keep their log
columns (Ivester & Heigel's linearised power law, :mod:`models.fit`):

.. math::

    y_j = \ln Y_j - \sum_{f} e_f \ln x_{fj}, \qquad
    y_j = \ln K + \sum_{i \text{ free}} e_i \ln x_{ij} + r_j

Every error names the field and the value (the column by its label, the point by its row).

References
----------
.. [1] Ivester & Heigel, Smart Machining Systems (NIST), "Cutting Force Models": regression of
   the linearised power law.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from models.errors import InputError
from models.fit_design import check_design, check_positive, vector

#: Name of the intercept in a fit's ``stderr`` and ``parameters``.
LN_K = "ln_K"

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class LogPoints:
    """The checked points of a fit, on the log scale.

    Parameters
    ----------
    names : tuple of str
        Every variable, in the order given.
    fixed : Mapping[str, float]
        The exponents not fitted [-].
    free : tuple of str
        The variables whose exponents are fitted, in the order given.
    y : ndarray
        The left-hand side ``ln Y − Σ e_f ln x_f`` of every point [-].
    free_logs : tuple of ndarray
        ``ln x_i`` of every point, one column per free variable [-].
    """

    names: tuple[str, ...]
    fixed: Mapping[str, float]
    free: tuple[str, ...]
    y: FloatArray
    free_logs: tuple[FloatArray, ...]

    @property
    def n(self) -> int:
        """Number of points."""
        return int(self.y.size)


def log_points(
    response: Sequence[float] | FloatArray,
    variables: Mapping[str, Sequence[float] | FloatArray],
    fixed: Mapping[str, float],
    response_name: str,
    labels: Mapping[str, str],
    rows: Sequence[object] | None,
) -> LogPoints:
    """Check the data of a fit and take its logarithms (see :func:`models.fit.fit_power_law`).

    Raises
    ------
    InputError
        Columns of unequal length; a value that is not positive and finite; a fixed exponent
        that is not finite or lacks values; fewer than ``p + 1`` points; a constant column;
        collinear columns.
    """
    names = list(variables)
    y_raw = vector(response, response_name)
    columns = {name: vector(variables[name], labels.get(name, name)) for name in names}
    _check_columns(y_raw, columns, response_name, labels, rows)
    _check_fixed(fixed, columns)
    free = [name for name in names if name not in fixed]
    _check_enough_points(y_raw.size, free)
    logs = {name: np.log(column) for name, column in columns.items()}
    y = np.log(y_raw)
    for name, exponent in fixed.items():
        if name in logs:
            y = y - exponent * logs[name]
    free_logs = [logs[name] for name in free]
    check_design(free, [columns[name] for name in free], free_logs, labels)
    return LogPoints(tuple(names), fixed, tuple(free), y, tuple(free_logs))


def _check_columns(
    y_raw: FloatArray,
    columns: Mapping[str, FloatArray],
    response_name: str,
    labels: Mapping[str, str],
    rows: Sequence[object] | None,
) -> None:
    """One value per point in every column, one label per point, every value positive."""
    n = y_raw.size
    for name, column in columns.items():
        if column.size != n:
            raise InputError(
                labels.get(name, name),
                f"{column.size} values",
                f"the response {response_name} has {n}; every column needs one value per point",
            )
    row_names = list(rows) if rows is not None else list(range(n))
    if len(row_names) != n:
        raise InputError("rows", f"{len(row_names)} labels", f"expected one per point ({n})")
    check_positive(y_raw, response_name, row_names)
    for name, column in columns.items():
        check_positive(column, labels.get(name, name), row_names)


def _check_fixed(fixed: Mapping[str, float], columns: Mapping[str, FloatArray]) -> None:
    """Every fixed exponent is finite, and one other than 0 has its variable's values."""
    for name, exponent in fixed.items():
        if not math.isfinite(exponent):
            raise InputError(f"fixed.{name}", exponent, "must be a finite number")
        if name not in columns and exponent != 0.0:
            raise InputError(
                f"fixed.{name}", exponent, f"a fixed exponent other than 0 needs the {name} values"
            )


def _check_enough_points(n: int, free: Sequence[str]) -> None:
    """At least ``p + 1`` points: ``s`` needs a residual degree of freedom."""
    p = 1 + len(free)
    if n <= p:
        params = ", ".join([LN_K, *free])
        raise InputError(
            "n",
            n,
            f"{n} points cannot fit {p} parameters ({params}) and leave a residual to estimate "
            f"s; need at least {p + 1}",
        )
