"""The one place the environment is read: the database URL of the REST service and the CLI.

``RCB_DATABASE_URL`` names the database when no URL is given (``rcb --db``, ``create_app``);
without it the embedded default ``./rcb.db`` (:data:`db.engine.DEFAULT_URL`). The serving code
hands a URL to its uvicorn workers through the same variable (:func:`hand_to_workers`), since
a worker imports the app factory by name and takes no arguments.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass

from db.engine import DEFAULT_URL

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
    env = os.environ if environ is None else environ
    return given or env.get(DATABASE_URL_VAR) or DEFAULT_URL


def hand_to_workers(url: str) -> None:
    """Put ``url`` where the workers' app factory reads it (:meth:`Settings.from_env`)."""
    os.environ[DATABASE_URL_VAR] = url
