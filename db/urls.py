"""Database URLs checked where they come in, and what a database's failures mean to its user.

A new user's first mistakes with ``--db`` (or ``$RCB_DATABASE_URL``) each get one line with the
fix (issue 30): a file path where a URL belongs, a driver rcb does not install (``mysql://``),
an in-memory SQLite database (nothing of it would outlive the command), a server that does not
answer, a database not yet migrated. :func:`check` refuses a URL before an engine is made;
:func:`explain` turns SQLAlchemy's error on connecting into a reason naming host and port;
:func:`revision` reads where a database's migrations stand.
"""

from __future__ import annotations

import os
import re

from sqlalchemy import Connection, inspect, text
from sqlalchemy.engine import URL, make_url
from sqlalchemy.exc import ArgumentError, DBAPIError

from models.errors import InputError

#: The drivers rcb installs (dependencies in pyproject.toml), each with an example URL.
SUPPORTED = {
    "sqlite": "sqlite:///./rcb.db",
    "postgresql+psycopg": "postgresql+psycopg://user@host:5432/rcb",
}
#: The table Alembic keeps the database's revision in.
VERSION_TABLE = "alembic_version"
_SUPPORTED_TEXT = ", ".join(f"{name} ({example})" for name, example in SUPPORTED.items())
_BAD_PORT = (
    "the port after the host must be a whole number from 1 to 65535 "
    "(host:5432; an IPv6 address in brackets, [::1]:5432)"
)


def check(url: str, field: str = "--db") -> URL:
    """``url`` parsed, if rcb can keep its data there; else InputError naming ``field``.

    Refused: text that is not a URL (a file path gets its ``sqlite:///`` form, absolute), a
    port that is not a whole number from 1 to 65535 (``host:notaport``, an IPv6 address
    without its closing bracket), a driver rcb does not install, an in-memory SQLite
    database, and a SQLite path that is a directory.
    """
    try:
        parsed = make_url(url)
    except ArgumentError:
        raise InputError(field, url, _not_a_url(url)) from None
    except ValueError:  # SQLAlchemy's int() of the text after the host's last ':'
        raise InputError(field, _password_hidden(url), _BAD_PORT) from None
    if parsed.port is not None and not 0 < parsed.port < 65536:
        raise InputError(field, _shown(url, parsed), _BAD_PORT)
    name = parsed.drivername
    if name in ("sqlite", "sqlite+pysqlite"):
        if _in_memory(parsed):
            raise InputError(
                field,
                _shown(url, parsed),
                "an in-memory database keeps nothing after rcb exits; "
                f"give a file, e.g. {SUPPORTED['sqlite']}",
            )
        if os.path.isdir(parsed.database or ""):
            inside = os.path.join(os.path.abspath(parsed.database or ""), "rcb.db")
            reason = (
                f"is a directory, not a database file; give a file in it, e.g. sqlite:///{inside}"
            )
            raise InputError(field, _shown(url, parsed), reason)
        return parsed
    if name == "postgresql+psycopg":
        return parsed
    raise InputError(
        field, _shown(url, parsed), f"unsupported database driver {name!r}; use {_SUPPORTED_TEXT}"
    )


def _not_a_url(url: str) -> str:
    """Why ``url`` is not a URL, with the URL it may have meant."""
    if "://" not in url and url.strip():
        path = os.path.abspath(os.path.expanduser(url))
        return f"a file path, not a database URL; write it as sqlite:///{path}"
    return f"not a database URL; use {_SUPPORTED_TEXT}"


def _password_hidden(url: str) -> str:
    """``url``, which SQLAlchemy cannot parse, with a password in it shown as ``***``."""
    return re.sub(r"^([^:/]*://[^:/@]*:).*@", r"\1***@", url)


def _in_memory(parsed: URL) -> bool:
    database = parsed.database or ""
    return database in ("", ":memory:") or parsed.query.get("mode") == "memory"


def _shown(url: str, parsed: URL) -> str:
    """``url`` as given, or with its password hidden if it has one."""
    return url if parsed.password is None else parsed.render_as_string(hide_password=True)


def explain(err: Exception, url: str) -> str | None:
    """What a failure to connect to ``url`` means, with the fix; None for any other error."""
    if not isinstance(err, DBAPIError) or not _connecting(err):
        return None
    parsed = make_url(url)
    text = str(_cause(err))
    first = first_line(err)
    if parsed.get_backend_name() == "sqlite":
        if "unable to open database file" in text:
            folder = os.path.dirname(os.path.abspath(parsed.database or "."))
            return f"cannot open or create the file (does the directory {folder} exist?)"
        return None
    where = f"{parsed.host or 'localhost'}:{parsed.port or 5432}"
    if "does not exist" in text and "database" in text:
        return (
            f"the server at {where} has no database {parsed.database!r}; "
            f"create it (createdb -h {parsed.host or 'localhost'} -p {parsed.port or 5432} "
            f"{parsed.database}), then rcb db upgrade"
        )
    if "authentication failed" in text or "password" in text:
        return f"the server at {where} refused the login ({first})"
    if "resolve host" in text or "translate host" in text:
        return f"no such host {parsed.host!r} (a typing mistake in the URL?)"
    if "refused" in text or "timeout" in text or "timed out" in text:
        return f"the server does not answer at {where} (is PostgreSQL running there?)"
    return f"cannot connect to the server at {where} ({first})"


def cannot_use(err: Exception, url: str) -> str:
    """Why the database at ``url`` cannot be used, after ``err`` (SQLAlchemy's).

    :func:`explain`'s reason and fix when it failed on connecting; else the driver's class
    and first line, ``cannot use this database (OperationalError: attempt to write a
    readonly database)``.
    """
    reason = explain(err, url)
    if reason is not None:
        return reason
    return f"cannot use this database ({_cause(err).__class__.__name__}: {first_line(err)})"


def first_line(err: BaseException) -> str:
    """The first line of what ``err`` (or the driver's error under it) says, else its class."""
    cause = _cause(err)
    lines = str(cause).strip().splitlines()
    return lines[0] if lines else cause.__class__.__name__


def _cause(err: BaseException) -> BaseException:
    """The driver's error under SQLAlchemy's ``err`` (``sqlite3.OperationalError``), or ``err``."""
    orig = getattr(err, "orig", None) if isinstance(err, DBAPIError) else None
    return orig if isinstance(orig, BaseException) else err


def unknown_revision(found: str) -> str:
    """Why a database at a revision this rcb has no migration for is refused (a newer rcb's).

    Neither used nor migrated: Alembic cannot go from a revision it does not know.
    """
    return f"the database is at revision {found!r}, unknown to this rcb (a newer one?)"


#: PostgreSQL's read_only_sql_transaction (a standby, ``default_transaction_read_only``).
_PG_READ_ONLY = "25006"


def read_only(err: BaseException) -> bool:
    """Whether ``err`` says the database takes no writes.

    A SQLite file (or its directory) read-only: SQLITE_READONLY; a PostgreSQL standby or
    read-only transaction: SQLSTATE 25006.
    """
    if not isinstance(err, DBAPIError):
        return False
    if getattr(err.orig, "sqlstate", None) == _PG_READ_ONLY:
        return True
    return "readonly database" in str(err.orig)


def _connecting(err: DBAPIError) -> bool:
    """Whether ``err`` happened while connecting (psycopg and sqlite3 both say so)."""
    text = str(err.orig)
    return any(
        sign in text
        for sign in ("connection failed", "failed to resolve host", "unable to open database file")
    )


def revision(connection: Connection) -> str | None:
    """The database's Alembic revision; None when it was never migrated (no version table)."""
    if not inspect(connection).has_table(VERSION_TABLE):
        return None
    rows = connection.execute(text(f"SELECT version_num FROM {VERSION_TABLE}")).all()
    if len(rows) <= 1:  # read without Alembic: a command's start does not load it
        return None if not rows else str(rows[0][0])
    from alembic.runtime.migration import MigrationContext  # several heads: Alembic says so

    return MigrationContext.configure(connection).get_current_revision()


#: A query parameter of a PostgreSQL URL that is this service's, not libpq's:
#: ``?pgbouncer=transaction`` says the server is reached through PgBouncer in transaction
#: pooling. Its server connections change between transactions, so psycopg prepares no
#: statement on the server (``prepare_threshold=None``: PgBouncer before 1.21, Debian 12's
#: 1.18, does not track them) and every lock this service takes is a transaction's
#: (:mod:`db.migrate`).
POOLER_PARAM = "pgbouncer"


def behind_pooler(url: URL) -> bool:
    """Whether ``url`` says PgBouncer in transaction pooling (:data:`POOLER_PARAM`)."""
    value = url.query.get(POOLER_PARAM)
    if value is None:
        return False
    if value != "transaction" or url.get_backend_name() != "postgresql":
        why = "only pgbouncer=transaction, on a postgresql URL (PgBouncer in transaction pooling)"
        raise InputError(POOLER_PARAM, value, why)
    return True


def without_pooler(url: URL) -> URL:
    """``url`` without :data:`POOLER_PARAM`, as the driver takes it."""
    return url.difference_update_query([POOLER_PARAM])
