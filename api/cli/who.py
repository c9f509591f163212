"""``--by NAME``: who did a write at the command line, for the audit log and the history.

Every ``rcb`` command that writes to the database (``replan``, ``keys create|revoke``,
``db prune``) takes ``--by``; the default is the operating-system user. The actor is recorded
as ``cli:NAME``, as a REST request's is ``key:ID``, so the audit log and a replan's setpoint
version say who did it and through which door.
"""

from __future__ import annotations

import getpass
import os
from typing import TYPE_CHECKING, Annotated

import typer

from models.errors import InputError

if TYPE_CHECKING:
    from db.api_keys import Actor

#: Longest ``--by`` (the audit log's actor column holds 200 characters).
MAX_NAME = 100
#: The prefix of a command-line actor (a REST client's is ``key:``).
PREFIX = "cli:"
#: The name when the operating system cannot say who runs ``rcb``.
UNKNOWN = "unknown"

ByOption = Annotated[
    str | None,
    typer.Option(
        "--by",
        metavar="NAME",
        help="Who does this, for the audit log and history (default: the OS user).",
    ),
]


def os_user() -> str:
    """The operating-system user running ``rcb``; its uid, or ``unknown``, if it has no name.

    :func:`getpass.getuser` raises when neither ``LOGNAME``, ``USER``, ``LNAME`` nor
    ``USERNAME`` is set and the uid has no password-database entry (a container's user).
    """
    try:
        name = getpass.getuser().strip()
    except (OSError, KeyError, ImportError):
        name = ""
    if name:
        return name
    getuid = getattr(os, "getuid", None)
    return f"uid {getuid()}" if getuid is not None else UNKNOWN


def cli_actor(by: str | None) -> Actor:
    """The actor of a command-line write done by ``by`` (None: :func:`os_user`).

    Raises InputError naming ``--by`` for an empty name, one over :data:`MAX_NAME`
    characters, or one with a control or invisible formatting character.
    """
    from db.api_keys import CLI_ACTOR, Actor  # SQLAlchemy: only a command that writes loads it

    name = os_user() if by is None else by.strip()
    if not name:
        raise InputError("--by", by, "a name is needed (who does this)")
    if len(name) > MAX_NAME:
        raise InputError("--by", name, f"at most {MAX_NAME} characters")
    if not name.isprintable():
        raise InputError("--by", name, "no control or invisible characters")
    return Actor(None, CLI_ACTOR.role, PREFIX + name, CLI_ACTOR.plans)
