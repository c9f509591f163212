"""A value typer refused, in rcb's words: ``--limit = 'abc': must be a whole number``.

typer (0.29) coerces an option's value with pydantic, and its usage error was pydantic's
sentence: ``Invalid value for '--limit': Input should be a valid integer, unable to parse
string as an integer (got 'abc')``, worded unlike every other error of rcb
(``--strategy = 'x': must be one of ...``, :class:`models.errors.InputError`). :func:`said`
words each of pydantic's errors as rcb words an input's (the option, the value as given, what
it must be), in the words of the service's problems
(:func:`api.rest.schemas.common.plain_message`).
"""

from __future__ import annotations

import sys
from typing import Any


def said(err: BaseException) -> str | None:
    """``err`` (a usage error typer raised from pydantic's) in rcb's words; None if not such."""
    pydantic = sys.modules.get("pydantic")  # loaded by typer's coercion when it ran
    cause = err.__cause__
    if pydantic is None or not isinstance(cause, pydantic.ValidationError):
        return None
    name = param_name(getattr(err, "param", None))
    return "; ".join(f"{name} = {_given(e.get('input'))}: {_must(e)}" for e in cause.errors())


def _given(value: Any) -> str:
    """The value as typed: a number bare (``--parts = 5000``), any other text quoted."""
    if isinstance(value, str):
        try:
            float(value)
        except ValueError:
            return repr(value)
        return value if value.strip() == value and value.isascii() else repr(value)
    return repr(value)


def param_name(param: Any) -> str:
    """The option as typed (its long name), or the argument as the help names it.

    An argument's metavar (``ID``), else its name in capitals (``KEY_ID``), as other errors
    name arguments (``PLAN``, ``FILE``): typer's arguments have no ``human_readable_name``.
    """
    if param is None:
        return "value"
    opts = [o for o in getattr(param, "opts", ()) if o.startswith("-")]
    if opts:
        return str(max(opts, key=len))
    for name in (getattr(param, "human_readable_name", None), getattr(param, "metavar", None)):
        if name:
            return str(name)
    name = getattr(param, "name", None)
    return name.upper() if name else "value"


def _must(error: Any) -> str:
    """What the value must be, for one of pydantic's errors: as the service says it."""
    from api.rest.schemas.common import plain_message  # loaded only for an error: not at start

    return plain_message(error)
