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

from models import fields
from models.errors import InputError

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


def _listed_numbers(value: object, path: str) -> None:
    """A list of finite numbers (their range: the document's to check); errors name ``path[i]``."""
    if not isinstance(value, list):
        raise InputError(path, value, "must be a list of numbers")
    for i, v in enumerate(value):
        fields.number(v, f"{path}[{i}]", largest=math.inf)
