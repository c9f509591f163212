"""The one place the environment is read: the database URL of the REST service and the CLI.

``RCB_DATABASE_URL`` names the database when no URL is given (``rcb --db``, ``create_app``);
without it the embedded default ``./rcb.db`` (:data:`db.engine.DEFAULT_URL`). The serving code
hands a URL to its uvicorn workers through the same variable (:func:`hand_to_workers`), since
a worker imports the app factory by name and takes no arguments. ``RCB_AUTH_FAILURE_BURST``:
the wrong API keys one client address may send at once before 429 (default 60).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass

from models.errors import InputError

#: The environment variable naming the database.
DATABASE_URL_VAR = "RCB_DATABASE_URL"


@dataclass(frozen=True)
class Settings:
    """What the service and the CLI take from the environment.

    Parameters
    ----------
    database_url : str
        SQLAlchemy URL of the database (migrated beforehand: ``rcb db upgrade``).
    """

    database_url: str

    @classmethod
    def from_env(cls, environ: Mapping[str, str] | None = None) -> Settings:
        """The settings of ``environ`` (default: the process environment)."""
        return cls(database_url=database_url(None, environ))


def database_url(given: str | None, environ: Mapping[str, str] | None = None) -> str:
    """``given``, else ``$RCB_DATABASE_URL``, else the embedded default ``./rcb.db``."""
    # imported here: db.engine loads SQLAlchemy, which rcb --help does not need
    from db.engine import DEFAULT_URL

    env = os.environ if environ is None else environ
    return given or env.get(DATABASE_URL_VAR) or DEFAULT_URL


def hand_to_workers(url: str) -> None:
    """Put ``url`` where the workers' app factory reads it (:meth:`Settings.from_env`)."""
    os.environ[DATABASE_URL_VAR] = url


#: The environment variable with the wrong keys one client address may send at once.
AUTH_FAILURE_BURST_VAR = "RCB_AUTH_FAILURE_BURST"
#: Its default (api.services.throttle).
AUTH_FAILURE_BURST = 60


def auth_failure_burst(environ: Mapping[str, str] | None = None) -> int:
    """``$RCB_AUTH_FAILURE_BURST`` (1 to 1000000), else 60.

    Raises InputError naming the variable for a malformed value (``rcb serve`` checks it
    before serving, so a worker never meets one).
    """
    text = (os.environ if environ is None else environ).get(AUTH_FAILURE_BURST_VAR)
    if text is None:
        return AUTH_FAILURE_BURST
    if not (text.isascii() and text.isdigit() and 1 <= int(text) <= 10**6):
        raise InputError(AUTH_FAILURE_BURST_VAR, text, "expected a whole number 1 to 1000000")
    return int(text)
