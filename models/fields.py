"""Checked reading of nested mappings (TOML or JSON) into numbers and names.

Every error names the dotted path of the offending field and its value.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

from models.errors import InputError


def mapping(value: object, path: str) -> Mapping[str, Any]:
    """Return ``value`` as a mapping with string keys, or raise naming ``path``."""
    if not isinstance(value, Mapping) or not all(isinstance(k, str) for k in value):
        raise InputError(path, value, "must be a table of named fields")
    return value


def only_keys(data: Mapping[str, Any], allowed: Iterable[str], path: str) -> None:
    """Refuse keys of ``data`` that are not in ``allowed`` (catches misspelt fields)."""
    allowed = tuple(allowed)
    for key in data:
        if key not in allowed:
            where = f"{path}.{key}" if path else key
            raise InputError(
                where, data[key], f"unknown field; expected one of: {', '.join(allowed)}"
            )


def text(data: Mapping[str, Any], key: str, path: str, default: str | None = None) -> str:
    """A non-empty string field."""
    where = f"{path}.{key}" if path else key
    if key not in data:
        if default is not None:
            return default
        raise InputError(where, None, "required field missing")
    value = data[key]
    if not isinstance(value, str) or not value.strip():
        raise InputError(where, value, "must be a non-empty string")
    return value


def number(
    value: object, path: str, *, positive: bool = False, minimum: float | None = None
) -> float:
    """A finite real number (not a bool), optionally positive or at least ``minimum``."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(path, value, "must be a number")
    result = float(value)
    if not math.isfinite(result):
        raise InputError(path, value, "must be a finite number")
    if positive and result <= 0:
        raise InputError(path, value, "must be greater than 0")
    if minimum is not None and result < minimum:
        raise InputError(path, value, f"must be at least {minimum:g}")
    return result


def optional_number(
    data: Mapping[str, Any], key: str, path: str, *, positive: bool = False
) -> float | None:
    """``number`` for an optional field; ``None`` when absent."""
    if key not in data:
        return None
    return number(data[key], f"{path}.{key}" if path else key, positive=positive)


def number_table(
    value: object,
    path: str,
    allowed: Iterable[str],
    *,
    positive: bool = False,
    minimum: float | None = None,
) -> dict[str, float]:
    """A table of numbers whose keys must be among ``allowed``."""
    table = mapping(value, path)
    only_keys(table, allowed, path)
    return {
        k: number(v, f"{path}.{k}", positive=positive, minimum=minimum) for k, v in table.items()
    }
