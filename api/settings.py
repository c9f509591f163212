"""The one place the environment is read: the database URL of the REST service and the CLI.

``RCB_DATABASE_URL`` names the database when no URL is given (``rcb --db``, ``create_app``);
without it the embedded default ``./rcb.db`` (:data:`db.engine.DEFAULT_URL`). The serving code
hands a URL to its uvicorn workers through the same variable (:func:`hand_to_workers`), since
a worker imports the app factory by name and takes no arguments. ``RCB_AUTH_FAILURE_BURST``:
the wrong API keys one client address may send at once before 429 (default 60).
``RCB_DB_POOL_SIZE``, ``RCB_DB_MAX_OVERFLOW``, ``RCB_DB_POOL_TIMEOUT``: each worker's database
connections and how long a request waits for one before 503 (:class:`db.engine.Pool`).
``RCB_HTTP_*``: the HTTP connections' timeouts and caps (:class:`HttpLimits`).
``RCB_FORWARDED_ALLOW_IPS``: the proxies whose ``X-Forwarded-For`` names the client
(:func:`trusted_proxies`).
"""

from __future__ import annotations

import ipaddress
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from models.errors import InputError

if TYPE_CHECKING:
    from db.engine import Pool

#: The environment variable naming the database.
DATABASE_URL_VAR = "RCB_DATABASE_URL"


@dataclass(frozen=True)
class Settings:
    """What the service and the CLI take from the environment.

    Parameters
    ----------
    database_url : str
        SQLAlchemy URL of the database (migrated beforehand: ``rcb db upgrade``).
    pool : db.engine.Pool
        The database connections of a worker.
    """

    database_url: str
    pool: Pool = field(default_factory=lambda: pool({}))

    @classmethod
    def from_env(cls, environ: Mapping[str, str] | None = None) -> Settings:
        """The settings of ``environ`` (default: the process environment)."""
        return cls(database_url=database_url(None, environ), pool=pool(environ))


def database_url(given: str | None, environ: Mapping[str, str] | None = None) -> str:
    """``given``, else ``$RCB_DATABASE_URL``, else the embedded default ``./rcb.db``."""
    # imported here: db.engine loads SQLAlchemy, which rcb --help does not need
    from db.engine import DEFAULT_URL

    env = os.environ if environ is None else environ
    return given or env.get(DATABASE_URL_VAR) or DEFAULT_URL


def database_field(given: str | None, environ: Mapping[str, str] | None = None) -> str:
    """Where :func:`database_url` found the URL, as an error names it.

    ``--db`` when given (or for the default), ``RCB_DATABASE_URL`` when taken from there.
    """
    env = os.environ if environ is None else environ
    return DATABASE_URL_VAR if not given and env.get(DATABASE_URL_VAR) else "--db"


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
    return _whole(AUTH_FAILURE_BURST_VAR, 1, 10**6, AUTH_FAILURE_BURST, environ)


#: The environment variable with the proxies trusted to name the client (rcb serve's option).
FORWARDED_VAR = "RCB_FORWARDED_ALLOW_IPS"
#: Its default: no proxy, the peer is the client. Not uvicorn's (a proxy on this host): with
#: it, any process on the host picked its address per request by sending the header, and its
#: wrong keys never met the limit (a lockout review). A proxy, on this host or another, is
#: named; a valid key passes a limited address anyway, so a proxy left unnamed costs its
#: clients one shared wrong-key burst, never their service.
FORWARDED_DEFAULT = "none"
#: The most addresses and networks it may list.
MAX_FORWARDED = 64


def trusted_proxies(given: str | None = None, environ: Mapping[str, str] | None = None) -> str:
    """The proxies whose ``X-Forwarded-For`` names the client, as uvicorn takes them.

    ``given`` (``rcb serve --forwarded-allow-ips``), else ``$RCB_FORWARDED_ALLOW_IPS``, else
    :data:`FORWARDED_DEFAULT`: comma-separated addresses and networks (``10.0.0.0/8``), ``*``
    (every peer: only behind a proxy that is the sole way in) or ``none`` (the header is never
    read: the peer is the client). The client address is what the wrong-key limit counts and
    the audit log shows (:func:`api.rest.deps.client_of`). Uvicorn takes a malformed address
    for a literal that never matches; here it is refused, naming the option and the value.
    """
    where = "--forwarded-allow-ips" if given is not None else FORWARDED_VAR
    env = os.environ if environ is None else environ
    text = given if given is not None else env.get(FORWARDED_VAR, FORWARDED_DEFAULT)
    value = text.strip()
    if value.lower() == "none":
        return ""
    if value == "*":
        return value
    items = [item.strip() for item in value.split(",")]
    if not value or len(items) > MAX_FORWARDED:
        why = f"1 to {MAX_FORWARDED} comma-separated addresses or networks, '*' or 'none'"
        raise InputError(where, text, f"must be {why}")
    for item in items:
        try:
            ipaddress.ip_network(item, strict=False)
        except ValueError:
            raise InputError(where, text, f"{item!r} is not an IP address or network") from None
    return ",".join(items)


#: The environment variables of a worker's connection pool, with their ranges.
POOL_VARS = {
    "RCB_DB_POOL_SIZE": (1, 1000),
    "RCB_DB_MAX_OVERFLOW": (0, 1000),
    "RCB_DB_POOL_TIMEOUT": (1, 600),
}


def pool(environ: Mapping[str, str] | None = None) -> Pool:
    """A worker's connection pool, from the environment.

    ``$RCB_DB_POOL_SIZE``, ``$RCB_DB_MAX_OVERFLOW`` and ``$RCB_DB_POOL_TIMEOUT`` (whole
    seconds), each defaulting to :class:`db.engine.Pool`'s. Raises InputError naming the
    variable for a malformed or out-of-range value (``rcb serve`` checks them first).
    """
    from db.engine import Pool

    default = Pool()
    given = (default.size, default.overflow, int(default.timeout_s))
    size, overflow, timeout_s = (
        _whole(name, low, high, value, environ)
        for (name, (low, high)), value in zip(POOL_VARS.items(), given, strict=True)
    )
    return Pool(size=size, overflow=overflow, timeout_s=float(timeout_s))


def _whole(name: str, low: int, high: int, default: int, environ: Mapping[str, str] | None) -> int:
    """The whole number in ``$name`` (``low`` to ``high``), else ``default``."""
    text = (os.environ if environ is None else environ).get(name)
    if text is None:
        return default
    if not (text.isascii() and text.isdigit() and low <= int(text) <= high):
        raise InputError(name, text, f"expected a whole number {low} to {high}")
    return int(text)


@dataclass(frozen=True)
class HttpLimits:
    """How long an HTTP connection may take, and how many a worker holds (``rcb serve``).

    Parameters
    ----------
    header_timeout_s : int
        From the connection's opening (or a request's first byte on a kept-alive connection)
        to the end of the request's head [s]; then the connection is closed.
    body_timeout_s : int
        From the end of a request's head to the end of its body [s]; then closed.
    keep_alive_timeout_s : int
        A kept-alive connection idle between requests is closed after this [s].
    per_client : int
        Connections one client address may hold at once; more are refused (503, closed).
    total : int or None
        Connections a worker holds at once; None: below its open-file limit
        (:func:`api.rest.connections.total_cap`). When full, the oldest connection still
        waiting for a request's head is closed to admit a new one.
    """

    header_timeout_s: int = 10
    body_timeout_s: int = 30
    keep_alive_timeout_s: int = 5
    per_client: int = 64
    total: int | None = None


#: The environment variables of :class:`HttpLimits`, by field, with their ranges.
HTTP_VARS = {
    "header_timeout_s": ("RCB_HTTP_HEADER_TIMEOUT", 1, 3600),
    "body_timeout_s": ("RCB_HTTP_BODY_TIMEOUT", 1, 3600),
    "keep_alive_timeout_s": ("RCB_HTTP_KEEP_ALIVE_TIMEOUT", 1, 3600),
    "per_client": ("RCB_HTTP_MAX_CONNECTIONS_PER_CLIENT", 1, 10**6),
    "total": ("RCB_HTTP_MAX_CONNECTIONS", 2, 10**6),
}


def http_limits(environ: Mapping[str, str] | None = None) -> HttpLimits:
    """The :class:`HttpLimits` of the environment (``$RCB_HTTP_HEADER_TIMEOUT`` ...).

    Raises InputError naming the variable for a malformed or out-of-range value (``rcb serve``
    checks them before serving).
    """
    default = HttpLimits()
    given = {
        name: _whole(variable, low, high, getattr(default, name) or 0, environ)
        for name, (variable, low, high) in HTTP_VARS.items()
    }
    total = given.pop("total") or None  # 0: not given (derived from the file limit)
    return HttpLimits(**given, total=total)
