"""Checked numbers and names: the one home of input checking for every package.

Reads nested mappings (TOML or JSON) into numbers and names, checks the numeric fields of frozen
dataclasses (calibrations, the virtual mill's parts) and stores them back as plain floats.
Every error names the dotted path of the offending field and its value. Every number is within
:data:`models.bounds.LARGEST` in magnitude and every text within :data:`models.bounds.MAX_TEXT`
characters (an identifier :data:`models.bounds.MAX_IDENTITY`), and a positive number at least
:data:`models.bounds.SMALLEST_POSITIVE`: the bounds REST's schemas apply,
so a plan file and a plan posted to REST are bounded alike. A few readers take their bounds
from the caller and state them in one message whatever went wrong (:func:`text_within`,
:func:`number_within`, :func:`whole_within`): ``collector.toml``'s, which an operator reads on
the collector's console.
"""

from __future__ import annotations

import math
import numbers
import unicodedata
from collections.abc import Iterable, Mapping
from typing import Any, overload

import numpy as np

from models.bounds import LARGEST, MAX_IDENTITY, MAX_TEXT, SMALLEST_POSITIVE
from models.errors import InputError
from models.misspelt import unknown_field

#: Unicode categories an identifier may not hold, and what the refusal calls them: controls,
#: format characters (zero-width space and joiners, soft hyphen, BOM, bidirectional controls:
#: invisible, so two spellings would look alike), surrogates, line and paragraph separators.
_REFUSED_CATEGORIES = {
    "Cc": "control characters",
    "Cf": "invisible format characters",
    "Cs": "surrogates",
    "Zl": "control characters",
    "Zp": "control characters",
}


def identity(value: str) -> str:
    """A serial or a name as it is compared and stored: NFKC, without surrounding white space.

    Normalised: compatibility forms (full-width ``ＧＯＯＤ-１`` is ``GOOD-1``), decomposed
    accents (NFD ``É`` is the composed ``É``) and white space at either end (``'GOOD-1 '``).
    Refused (:class:`ValueError`): a control, format (zero-width, bidirectional), surrogate,
    line or paragraph separator character anywhere, which no one can see or type; nothing left;
    more than :data:`MAX_IDENTITY` characters. Case is kept (serials may be case-sensitive).
    """
    for i, char in enumerate(value):
        kind = _REFUSED_CATEGORIES.get(unicodedata.category(char))
        if kind is not None:
            name = unicodedata.name(char, "")
            raise ValueError(
                f"must not contain {kind} (U+{ord(char):04X}{' ' + name if name else ''} at {i})"
            )
    normal = unicodedata.normalize("NFKC", value).strip()
    if not normal:
        raise ValueError("must not be blank")
    if len(normal) > MAX_IDENTITY:
        raise ValueError(f"must be at most {MAX_IDENTITY} characters once normalised (NFKC)")
    return normal


def storable(value: str) -> str:
    r"""``value``, which any database column can hold: no NUL, no unpaired surrogate.

    Refused (:class:`ValueError`), as JSON can spell both (``"\u0000"``, ``"\ud800"``) and
    PostgreSQL stores neither: the REST schemas and :func:`text` apply this one rule.
    """
    if "\x00" in value:
        raise ValueError("must not contain NUL characters")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise ValueError("must be valid Unicode (an unpaired surrogate)") from None
    return value


def escaped(data: Any, *, nul: bool = False) -> Any:
    r"""``data`` (JSON-like) with every string valid Unicode: a lone surrogate as ``\ud800``.

    JSON may spell one, UTF-8 cannot encode it; ``nul``: a NUL as the text ``\x00`` too (for a
    database column, which holds neither; a JSON answer carries NUL as ``\u0000``). Keys too;
    a tuple becomes a list; anything else is returned as it is.
    """
    if isinstance(data, str):
        try:
            data.encode("utf-8")
        except UnicodeEncodeError:
            data = data.encode("utf-8", "backslashreplace").decode("utf-8")
        return data.replace("\x00", "\\x00") if nul else data
    if isinstance(data, dict):
        return {escaped(k, nul=nul): escaped(v, nul=nul) for k, v in data.items()}
    if isinstance(data, list | tuple):
        return [escaped(v, nul=nul) for v in data]
    return data


def identity_field(data: Mapping[str, Any], key: str, path: str) -> str:
    """A serial or a name field, as :func:`identity` normalises it; errors name the field."""
    value = text(data, key, path)
    try:
        return identity(value)
    except ValueError as err:
        raise InputError(f"{path}.{key}" if path else key, value, str(err)) from None


@overload
def without_nulls(data: Mapping[str, Any]) -> dict[str, Any]: ...
@overload
def without_nulls(data: object) -> object: ...
def without_nulls(data: object) -> object:
    """A JSON object with its ``null`` fields left out (as TOML, which has no null, says it).

    For a table whose fields are optional: ``"description": null`` is no description. Anything
    not an object is returned as it is, for its reader to refuse.
    """
    if not isinstance(data, Mapping):
        return data
    return {key: value for key, value in data.items() if value is not None}


def mapping(value: object, path: str) -> Mapping[str, Any]:
    """Return ``value`` as a mapping with string keys, or raise naming ``path``."""
    if not isinstance(value, Mapping) or not all(isinstance(k, str) for k in value):
        raise InputError(path, value, "must be a table of named fields")
    return value


def table(data: Mapping[str, Any], key: str, path: str = "") -> Mapping[str, Any]:
    """A required table (a TOML table, a JSON object) under ``key``; its fields are read apart.

    Absent or not a table: "required table missing", the field named by its dotted path.
    """
    where = f"{path}.{key}" if path else key
    value = data.get(key)
    if not isinstance(value, Mapping):
        raise InputError(where, value, "required table missing")
    return value


def only_keys(
    data: Mapping[str, Any], allowed: Iterable[str], path: str, *, list_allowed: bool = True
) -> None:
    """Refuse keys of ``data`` that are not in ``allowed`` (catches misspelt fields).

    ``list_allowed``: whether the refusal lists the allowed fields, or says "unknown field"
    only (``collector.toml``, whose fields its documentation lists).
    """
    allowed = tuple(allowed)
    for key in data:
        if key not in allowed:
            where = f"{path}.{key}" if path else key
            if not list_allowed:
                raise InputError(where, data[key], "unknown field")
            raise InputError(where, data[key], unknown_field(key, allowed))


def text(
    data: Mapping[str, Any],
    key: str,
    path: str,
    default: str | None = None,
    *,
    most: int = MAX_TEXT,
) -> str:
    """A non-empty string field of at most ``most`` characters.

    ``most`` is :data:`models.bounds.MAX_TEXT`, or :data:`models.bounds.MAX_IDENTITY` for a
    name that is not normalised (:func:`identity_field` bounds those it normalises).
    """
    where = f"{path}.{key}" if path else key
    if key not in data:
        if default is not None:
            return default
        raise InputError(where, None, "required field missing")
    value = data[key]
    if not isinstance(value, str) or not value.strip():
        raise InputError(where, value, "must be a non-empty string")
    if len(value) > most:
        raise InputError(where, value, f"must be at most {most} characters")
    try:
        return storable(value)
    except ValueError as err:
        raise InputError(where, value, str(err)) from None


def text_within(
    data: Mapping[str, Any], key: str, path: str, default: str | None = None, *, most: int
) -> str:
    """A string field of 1 to ``most`` characters, not blank; ``default`` when absent.

    One message for every refusal (absent without a default, not a string, blank, too long):
    "must be text of 1 to ``most`` characters", which says what would be accepted.
    """
    value = data.get(key, default)
    if not isinstance(value, str) or not value.strip() or len(value) > most:
        where = f"{path}.{key}" if path else key
        raise InputError(where, value, f"must be text of 1 to {most} characters")
    return value


def number_within(
    data: Mapping[str, Any],
    key: str,
    path: str,
    *,
    low: float,
    high: float,
    default: float | None = None,
) -> float:
    """A finite number field (an ``int`` or a ``float``, not a bool) in ``[low, high]``.

    ``default`` when absent; without one an absent field is "required field missing". Any
    other refusal is "must be a number" or "must be in [low, high]", the bounds as ``:g``.
    """
    where = f"{path}.{key}" if path else key
    if key not in data and default is None:
        raise InputError(where, None, "required field missing")
    value = data.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputError(where, value, "must be a number")
    if not low <= value <= high:
        raise InputError(where, value, f"must be in [{low:g}, {high:g}]")
    return float(value)


def whole_within(
    data: Mapping[str, Any], key: str, path: str, *, most: int, default: int | None = None
) -> int:
    """A whole number field (an ``int``, not a bool) from 1 to ``most``; ``default`` when absent.

    One message for every refusal, absence without a default included: "must be a whole
    number in 1..``most``".
    """
    value = data.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= most:
        where = f"{path}.{key}" if path else key
        raise InputError(where, value, f"must be a whole number in 1..{most}")
    return value


def number(
    value: object,
    path: str,
    *,
    positive: bool = False,
    minimum: float | None = None,
    largest: float = LARGEST,
) -> float:
    """A finite real number (not a bool) within ``±largest``, optionally positive or >= ``minimum``.

    Positive means at least :data:`models.bounds.SMALLEST_POSITIVE` (as REST's ``Positive``).

    Python ``int`` and ``float`` and numpy real scalars are numbers; bools (Python's or numpy's)
    are not. ``largest`` is :data:`models.bounds.LARGEST` unless a field has a tighter bound
    (an exponent: :data:`models.bounds.LARGEST_EXPONENT`).
    """
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise InputError(path, value, "must be a number")
    if not isinstance(value, int | float):
        value = float(value)  # a numpy scalar: errors show it as a plain float
    result = float(value)
    if not math.isfinite(result):
        raise InputError(path, value, "must be a finite number")
    if abs(result) > largest:
        raise InputError(path, value, f"must be within ±{largest:g}")
    if positive and result <= 0:
        raise InputError(path, value, "must be greater than 0")
    if positive and result < SMALLEST_POSITIVE:
        raise InputError(path, value, f"must be at least {SMALLEST_POSITIVE:g}")
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
    largest: float = LARGEST,
) -> dict[str, float]:
    """A table of numbers whose keys must be among ``allowed``; each as :func:`number` reads it."""
    table = mapping(value, path)
    only_keys(table, allowed, path)
    return {
        k: number(v, f"{path}.{k}", positive=positive, minimum=minimum, largest=largest)
        for k, v in table.items()
    }


def positive(value: object, path: str) -> float:
    """A finite number ``> 0``; the error names ``path`` and the value."""
    return number(value, path, positive=True)


def at_least(value: object, path: str, minimum: float = 0.0) -> float:
    """A finite number ``>= minimum``; the error names ``path`` and the value."""
    return number(value, path, minimum=minimum)


def uncertainty(value: object, path: str) -> float:
    """A finite uncertainty ``>= 0``."""
    return number(value, path, minimum=0.0)


def number_list(
    value: object, path: str, *, minimum: float | None = None, positive: bool = False
) -> tuple[float, ...]:
    """A list of finite numbers; errors name ``path[i]``."""
    if isinstance(value, str | bytes | Mapping) or not isinstance(value, Iterable):
        raise InputError(path, value, "must be a list of numbers")
    return tuple(
        number(v, f"{path}[{i}]", minimum=minimum, positive=positive) for i, v in enumerate(value)
    )


def count(value: object, path: str) -> int:
    """A whole number ``>= 0`` (not a bool)."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise InputError(path, value, "must be a whole number >= 0")
    return value


def check_field(
    obj: object,
    name: str,
    *,
    positive: bool = False,
    minimum: float | None = None,
    correlation: bool = False,
    optional: bool = False,
) -> None:
    """Check a numeric field of a frozen dataclass and store it back as a plain float.

    Parameters
    ----------
    obj : object
        The frozen dataclass, from its ``__post_init__``.
    name : str
        The field's name; errors name it.
    positive : bool
        Whether the value must be ``> 0``.
    minimum : float, optional
        Smallest allowed value.
    correlation : bool
        Whether the value is a correlation coefficient, in ``[-1, 1]``.
    optional : bool
        Whether ``None`` is allowed (and kept).
    """
    value = getattr(obj, name)
    if value is None and optional:
        return
    checked = number(value, name, positive=positive, minimum=minimum)
    if correlation and not -1.0 <= checked <= 1.0:
        raise InputError(name, value, "must be a correlation coefficient in [-1, 1]")
    object.__setattr__(obj, name, checked)


def check_fields(
    obj: object, *, positives: tuple[str, ...] = (), non_negatives: tuple[str, ...] = ()
) -> None:
    """Check numeric fields of a frozen dataclass (``> 0``, ``>= 0``) and store them as floats."""
    for name in positives:
        check_field(obj, name, positive=True)
    for name in non_negatives:
        check_field(obj, name, minimum=0.0)
