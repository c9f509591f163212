"""Exceptions raised by the models package."""

from __future__ import annotations


class ModelError(Exception):
    """Base class of every error raised by :mod:`models`."""


class InputError(ModelError, ValueError):
    """An input field holds a value that cannot be used.

    Parameters
    ----------
    field : str
        Dotted path of the offending field, e.g. ``tools[0].models.force_N.K``.
    value : object
        The offending value, as given.
    reason : str
        What is wrong with it.
    """

    def __init__(self, field: str, value: object, reason: str) -> None:
        self.field = field
        self.value = value
        self.reason = reason
        super().__init__(f"{field} = {value!r}: {reason}")


class ModelDomainError(InputError):
    """A model was given or asked for a value outside its domain."""
