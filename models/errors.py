"""Exceptions raised by the models package."""

from __future__ import annotations

#: The most characters of an offending value or field an error message echoes (as REST's).
MAX_ECHO = 200


def shown(value: object, limit: int = MAX_ECHO) -> str:
    """``repr(value)`` as a message echoes it: at most ``limit`` characters, cut with ``…``."""
    try:
        text = repr(value)
    except ValueError:  # an int of more digits than repr allows
        return "(a number too long to show)"
    return text if len(text) <= limit else text[: limit - 1] + "…"


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
        of its ``repr``).
    reason : str
        What is wrong with it.
    """

    def __init__(self, field: str, value: object, reason: str) -> None:
        self.field = field
        self.value = value
        self.reason = reason
        name = field if len(field) <= MAX_ECHO else field[: MAX_ECHO - 1] + "…"
        super().__init__(f"{name} = {shown(value)}: {reason}")


class ModelDomainError(InputError):
    """A model was given or asked for a value outside its domain."""
