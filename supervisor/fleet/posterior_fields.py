"""A posterior's fields in a fleet document, each of its type (:mod:`supervisor.fleet.document`).

Checked before the posterior is built, so that a document whose ``mean`` holds a string or
whose ``cov`` is missing is refused naming the field and its value
(``learned[0].posterior.mean[1] = 'a'``), not as "is not a posterior (could not convert
string to float)".
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from models import fields
from models.errors import InputError
from supervisor.rcb.posterior import Posterior

#: The fields every posterior holds (:meth:`~supervisor.rcb.posterior.Posterior.to_json`).
_POSTERIOR_KEYS = ("quantity", "names", "center", "context_exponents", "mean", "cov")


def posterior_fields(table: Mapping[str, Any], path: str) -> None:
    """Each field of a posterior present and of its type, an error naming the one that is not.

    The sizes and ranges are :func:`supervisor.fleet.document.read_item`'s to check.
    """
    missing = [key for key in _POSTERIOR_KEYS if key not in table]
    if missing:
        raise InputError(path, sorted(table), f"is not a posterior: no {', '.join(missing)}")
    fields.text(table, "quantity", path)
    names = table["names"]
    if not isinstance(names, list):
        raise InputError(f"{path}.names", names, "must be a list of input names")
    for i, name in enumerate(names):
        if not isinstance(name, str):
            raise InputError(f"{path}.names[{i}]", name, "must be an input's name")
    for key in ("center", "mean"):
        _listed_numbers(table[key], f"{path}.{key}")
    rows = table["cov"]
    if not isinstance(rows, list):
        raise InputError(f"{path}.cov", rows, "must be a list of rows of numbers")
    for i, row in enumerate(rows):
        _listed_numbers(row, f"{path}.cov[{i}]")
    exponents = fields.mapping(table["context_exponents"], f"{path}.context_exponents")
    for name, value in exponents.items():
        fields.number(value, f"{path}.context_exponents.{name}", largest=math.inf)
    if "edge_max" in table:
        fields.count(table["edge_max"], f"{path}.edge_max")
    for key in ("noise_scale2", "prior_widening"):
        if key in table:
            fields.number(table[key], f"{path}.{key}", largest=math.inf)
    _readings_fields(table, path)


def _readings_fields(table: Mapping[str, Any], path: str) -> None:
    """The readings' own information (:mod:`supervisor.rcb.information`): both or neither."""
    rows, vector = table.get("readings_information"), table.get("readings_vector")
    if (rows is None) != (vector is None):
        given, missing = (
            ("readings_information", "readings_vector")
            if vector is None
            else ("readings_vector", "readings_information")
        )
        raise InputError(f"{path}.{missing}", None, f"missing: {given} needs it")
    if rows is None:
        return
    if not isinstance(rows, list):
        raise InputError(f"{path}.readings_information", rows, "must be a list of rows of numbers")
    for i, row in enumerate(rows):
        _listed_numbers(row, f"{path}.readings_information[{i}]")
    _listed_numbers(vector, f"{path}.readings_vector")


def readings_held(belief: Posterior, path: str) -> None:
    """``belief``'s readings' information, if it keeps one, as its readings can make it.

    Of ``β``'s size, symmetric positive semidefinite (its numbers finite:
    :func:`posterior_fields`), and no more than ``belief``'s own precision (``P − J``, the
    start's part, positive semidefinite): a document's ``J`` is the evidence a fleet prior
    takes from it, so one that claimed more than the belief holds would make the fleet surer
    than any reading did.
    """
    if belief.readings_information is None or belief.readings_vector is None:
        return
    j, h = np.array(belief.readings_information), np.array(belief.readings_vector)
    size = len(belief.mean)
    if j.shape != (size, size) or h.shape != (size,):
        raise InputError(
            f"{path}.readings_information",
            [len(r) for r in belief.readings_information],
            f"must be {size} x {size} with a readings_vector of {size}, as the mean",
        )
    symmetric(j, f"{path}.readings_information", "an information")  # finite: posterior_fields
    scale = max(float(np.abs(belief.precision).max()), 1e-300)
    for matrix, why in ((j, _NOT_SEMIDEFINITE), (belief.precision - j, _MORE_THAN_HELD)):
        least = float(np.linalg.eigvalsh(0.5 * (matrix + matrix.T))[0])
        if least < -_ROUND_OFF * scale:
            raise InputError(f"{path}.readings_information", least, why)


def symmetric(matrix: np.ndarray, path: str, what: str) -> None:
    """``matrix`` equal to its transpose (to 1e-9), an error naming the first element that is not.

    ``path``: the matrix's field (``learned[0].posterior.cov``); ``what``: what it is ("a
    covariance"), which the error says is symmetric.
    """
    apart = ~np.isclose(matrix, matrix.T, rtol=1e-9, atol=0.0)
    if apart.any():  # the first element that differs from its mirror, by both names
        i, j = (int(k) for k in np.argwhere(apart)[0])
        name = path.rsplit(".", 1)[-1]
        raise InputError(
            f"{path}[{i}][{j}]",
            float(matrix[i, j]),
            f"must equal {name}[{j}][{i}] = {float(matrix[j, i])!r}: {what} is symmetric",
        )


#: Round-off a stored information may carry, relative to the belief's largest precision.
_ROUND_OFF = 1e-6
_NOT_SEMIDEFINITE = "an eigenvalue under 0: readings' information is positive semidefinite"
_MORE_THAN_HELD = "is more than the belief's precision holds (an eigenvalue of P - J under 0)"


def _listed_numbers(value: object, path: str) -> None:
    """A list of finite numbers (their range: the document's to check); errors name ``path[i]``."""
    if not isinstance(value, list):
        raise InputError(path, value, "must be a list of numbers")
    for i, v in enumerate(value):
        fields.number(v, f"{path}[{i}]", largest=math.inf)
