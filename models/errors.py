"""Exceptions raised by the models package."""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from typing import ParamSpec, TypeVar

T = TypeVar("T")
P = ParamSpec("P")

#: The most characters of an offending value or field an error message echoes (as REST's).
MAX_ECHO = 200


def shown(value: object, limit: int = MAX_ECHO) -> str:
    """``value`` as a message echoes it: at most ``limit`` characters, cut with ``…``.

    As a user writes it in a plan file or a request, not as Python holds it: ``true`` and
    ``false``, a table or a list as JSON (``{"K": 2500.0, "e": null}``, not ``{'K': 2500.0, 'e':
    None}``); text quoted and a number as its ``repr`` (``2.0`` stays ``2.0``: "must be a whole
    number" would not read right of ``2``).
    """
    try:
        text = _plain(value)
    except ValueError:  # an int of more digits than Python turns into text
        return "(a number too long to show)"
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _plain(value: object) -> str:
    """:func:`shown`'s text of ``value``, whole."""
    value = _scalar(value)
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, Mapping | list | tuple):
        return json.dumps(_jsonable(value), ensure_ascii=False)
    return repr(value)


def _jsonable(value: object) -> object:
    """``value`` for :func:`json.dumps`: what JSON has no value for, as its ``repr``."""
    value = _scalar(value)
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if value is None or isinstance(value, bool | int | float | str):
        return value
    return repr(value)


def _scalar(value: object) -> object:
    """A NumPy scalar (``np.True_``, ``np.float64(2.5)``) as Python's; anything else as it is.

    Told by its type's module, not by importing NumPy: ``rcb --help`` does not load it.
    """
    numpy = type(value).__module__ == "numpy" and getattr(value, "ndim", None) == 0
    if numpy and callable(item := getattr(value, "item", None)):
        scalar: object = item()
        return scalar
    return value


class ModelError(Exception):
    """Base class of every error raised by :mod:`models`."""


class InputError(ModelError, ValueError):
    """An input field holds a value that cannot be used.

    Parameters
    ----------
    field : str
        Dotted path of the offending field, e.g. ``tools[0].models.force_N.K``.
    value : object
        The offending value, as given (the message echoes at most :data:`MAX_ECHO` characters
        of it, as :func:`shown` writes it; None, no value, is not echoed).
    reason : str
        What is wrong with it.
    """

    def __init__(self, field: str, value: object, reason: str) -> None:
        self.field = field
        self.value = value
        self.reason = reason
        name = field if len(field) <= MAX_ECHO else field[: MAX_ECHO - 1] + "…"
        # no value (a field left out, a JSON null): the field alone, not "= None"
        said = name if value is None else f"{name} = {shown(value)}"
        super().__init__(f"{said}: {reason}")


class ModelDomainError(InputError):
    """A model was given or asked for a value outside its domain."""


class InputErrors(InputError):
    """Several independent errors of one input, refused together (``errors``, in input order).

    ``field``, ``value`` and ``reason`` are the first error's, so a caller that shows one error
    shows that; the message is one line per error.
    """

    def __init__(self, errors: Sequence[InputError]) -> None:
        first = errors[0]
        super().__init__(first.field, first.value, first.reason)
        self.errors = tuple(errors)
        self.args = ("\n".join(str(e) for e in self.errors),)  # str(): one line each


class Gathered:
    """The errors of the independent parts of one input, read one after another.

    :meth:`read` runs one part's reader and keeps its error (or errors) instead of raising;
    :meth:`raise_any` then raises the one error as it was, or :class:`InputErrors` for several.
    """

    def __init__(self) -> None:
        self.errors: list[InputError] = []

    def read(self, reader: Callable[P, T], *args: P.args, **kwargs: P.kwargs) -> T | None:
        """``reader(*args, **kwargs)``, or None when it refused its part (the error kept)."""
        try:
            return reader(*args, **kwargs)
        except InputErrors as err:
            self.errors.extend(err.errors)
        except InputError as err:
            self.errors.append(err)
        return None

    def raise_any(self) -> None:
        """Raise what was kept: nothing, the one error, or every one."""
        if len(self.errors) == 1:
            raise self.errors[0]
        if self.errors:
            raise InputErrors(self.errors)
