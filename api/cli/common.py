"""What every ``rcb`` command shares: the error contract, the database option, output, files.

Exit codes: 0 success, 2 bad input (one line naming the field and the value), 3 infeasible
(the limits that cannot be met) or a halted plan (its conflicts), 4 solver failure, 5 the
port of ``rcb serve`` is in use (:data:`api.rest.serving.EXIT_PORT_IN_USE`). The
command modules (:mod:`api.cli.optimize`, :mod:`api.cli.fit`, :mod:`api.cli.review` ...)
import from here and from their own output modules (:mod:`api.cli.tables`,
:mod:`api.cli.demo_view`), never from each other; :mod:`api.cli.main` registers them.
"""

from __future__ import annotations

import json
import math
import sys
import textwrap
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console

from api.cli.atomic import written_atomically
from api.services.errors import NotFoundError, PlanHaltedError
from db.errors import ConflictError
from models.bounds import LARGEST
from models.errors import InputError, InputErrors
from supervisor.errors import InfeasibleError, SolverError
from supervisor.rcb.settings import SETTINGS
from supervisor.rcb.strategies import REGISTRY, STRATEGY_NAMES

err_console = Console(stderr=True)

if TYPE_CHECKING:
    from sqlalchemy import Engine

#: The help of every ``--strategy``: each registered strategy with its summary.
STRATEGY_HELP = (
    "RCB strategy: " + "; ".join(f"{s.name}: {s.summary}" for s in REGISTRY.values()) + "."
)


def _strategy(value: str) -> str:
    """``--strategy``: a name of the registry, read when the option is (a plug-in may add one).

    Checked here, not by a ``Literal`` of typer: typer's message was its own and pydantic's
    (``Value error, 'foo' is not one of 'learn', ...``); this is one line of ``rcb``'s.
    """
    if value not in REGISTRY:
        raise InputError("--strategy", value, f"must be one of {', '.join(REGISTRY)}")
    return value


#: ``--strategy``: a name of :data:`supervisor.rcb.strategies.REGISTRY`, its summary in the help.
StrategyOption = Annotated[
    str,
    typer.Option(
        "--strategy",
        metavar=f"<{'|'.join(STRATEGY_NAMES)}>",
        help=STRATEGY_HELP,
        callback=_strategy,
    ),
]


def _setting_help() -> str:
    """Each setting of :data:`supervisor.rcb.settings.SETTINGS`: its form, range and doc."""
    parts = []
    for name, s in SETTINGS.items():
        if s.kind == "choice":
            parts.append(f"{name}={'|'.join(s.choices)}")
        elif s.kind == "floors":
            parts.append(f"floors.QUANTITY=VALUE >= {s.low:g} ({s.doc})")
        else:
            parts.append(f"{name} in {s.interval} ({s.doc})")
    return "; ".join(parts)


#: ``--rcb NAME=VALUE``: an RCB setting, its names, ranges and docs from the declaration.
RcbOption = Annotated[
    list[str] | None,
    typer.Option(
        "--rcb",
        metavar="NAME=VALUE",
        help="An RCB setting (repeatable), over the plan file's [rcb] table: " + _setting_help(),
    ),
]

#: ``--json`` of the commands that print tables otherwise.
JsonOption = Annotated[bool, typer.Option("--json", help="Print JSON instead of tables.")]

#: Every PLAN argument: a plan's id or its name (:func:`plan_of` turns it into the id).
PlanArg = Annotated[
    str, typer.Argument(metavar="PLAN", help="The plan's id or name (rcb plans lists them).")
]

DbOption = Annotated[
    str | None,
    typer.Option("--db", help="Database URL (default: $RCB_DATABASE_URL, else ./rcb.db)."),
]


class MissingOptionError(InputError):
    """An option the command needs here was not given (``--feed-mm-rev: required for ...``).

    There is no value to echo: the message names the option alone, not ``= None``.
    """

    def __init__(self, option: str, reason: str) -> None:
        super().__init__(option, None, reason)
        self.args = (f"{option}: {reason}",)


def say(text: str) -> None:
    """One message on stderr, as written (no markup, no wrapping)."""
    err_console.print(text, markup=False, highlight=False, soft_wrap=True)


#: The width a message is filled to: an 80-column terminal's.
WIDTH = 80


def say_filled(text: str) -> None:
    """One message filled to :data:`WIDTH` columns, its later lines indented by two.

    A word is never broken (a path or URL longer than a line keeps a line of its own).
    """
    say(
        textwrap.fill(
            text,
            width=WIDTH,
            subsequent_indent="  ",
            break_on_hyphens=False,
            break_long_words=False,
        )
    )


def say_error(text: str) -> None:
    """An error as ``rcb`` says it: filled to :data:`WIDTH` columns on a terminal.

    To a script or a log it stays one line, whole for ``grep``; a terminal would break a long
    line inside its words.
    """
    if err_console.is_terminal:
        say_filled(text)
    else:
        say(text)


def say_command(intro: str, command: str) -> None:
    """``intro command`` on one line when it fits :data:`WIDTH`; else the command alone below.

    The command is never broken, so it can be copied whole (one longer than a line stays one
    line, as ``rcb demo``'s are: :func:`api.cli.demo_view.stored_line`).
    """
    line = f"{intro} {command}"
    say(line if len(line) <= WIDTH else f"{intro}\n  {command}")


def again_db(db: str | None) -> str:
    """`` --db URL`` of a printed command to run next (a next page): the database just read.

    Without it the command read ``$RCB_DATABASE_URL`` or ``./rcb.db``, another database that may
    hold a plan of the same id, without a word. A URL with a password is never printed: it is
    shown as ``--db URL``, which the command refuses naming ``--db`` until it is filled in.
    """
    if db is None:
        return ""
    import shlex

    from sqlalchemy.engine import make_url

    return " --db URL" if make_url(db).password else f" --db {shlex.quote(db)}"


def as_option(err: InputError, fields: tuple[str, ...] = ("limit", "cursor")) -> InputError:
    """An input's error naming its option (``--limit``, ``--cursor``, ``--prior``).

    The service's ``fields`` (REST's query parameters) as options, each of several errors so;
    any other error (a stored value's, say) as it is.
    """
    if isinstance(err, InputErrors):
        return InputErrors([as_option(each, fields) for each in err.errors])
    if err.field not in fields:
        return err
    return InputError(f"--{err.field}", err.value, err.reason)


def refused_line(plan_id: int, why: str) -> str:
    """A plan whose stored settings this version refuses (``settings_refused``).

    One message, filled to 80 columns, as ``rcb plans`` and ``rcb plans show`` print it.
    """
    text = f"rcb: plan {plan_id} REFUSED: {why}"
    return textwrap.fill(text, width=80, subsequent_indent="  ", break_on_hyphens=False)


@contextmanager
def errors() -> Iterator[None]:
    """Turn the domain's errors into one line each on stderr and the exit code above."""
    try:
        yield
    except (InputError, NotFoundError, ConflictError) as err:
        for each in err.errors if isinstance(err, InputErrors) else (err,):  # a plan's every one
            say_error(f"rcb: error: {told(each)}")
        raise typer.Exit(2) from None
    except InfeasibleError as err:
        say_error(f"rcb: infeasible: {err}")
        raise typer.Exit(3) from None
    except PlanHaltedError as err:
        say_error(f"rcb: halted: {err}")
        raise typer.Exit(3) from None
    except SolverError as err:
        say_error(f"rcb: solver: {err}")
        raise typer.Exit(4) from None
    except Exception as err:
        if not _database_error(err):
            raise
        first = str(err).splitlines()[0] if str(err).strip() else err.__class__.__name__
        say_error(f"rcb: error: --db: cannot use this database ({first})")
        raise typer.Exit(2) from None


def told(err: Exception) -> str:
    """An error of the input as ``rcb`` says it: mostly as it is.

    A plan id the database does not hold is the service's ``plan_id = 99: not found`` (REST's
    field and value); on the command line it is said as an unknown name is
    (:func:`plan_of`): the PLAN argument, and where to find the plans. The commands whose
    use cases raise it take the plan as PLAN (``plans show``, ``history``, ``parts``,
    ``replan``, ``export``, ``gcode``); those with a ``--plan`` option say their own.
    """
    if isinstance(err, NotFoundError) and err.field == "plan_id":
        return f"PLAN = {err.value!r}: no plan with id {err.value!r} (rcb plans lists them)"
    return str(err)


def _database_error(err: Exception) -> bool:
    """Whether SQLAlchemy refused the database URL or could not use the database.

    SQLAlchemy is imported by the commands that open a database, only when they run (a
    command's help or another command does not load it): when it is not loaded, no error of
    its can have happened.
    """
    exc = sys.modules.get("sqlalchemy.exc")
    return exc is not None and isinstance(err, (exc.ArgumentError, exc.OperationalError))


def emit(data: object) -> None:
    """JSON on stdout (times in ISO 8601)."""
    typer.echo(json.dumps(data, indent=2, default=_jsonable))


def _jsonable(value: object) -> str:
    if isinstance(value, datetime):
        return value.isoformat()
    raise TypeError(type(value).__name__)


def shown(url: str) -> str:
    """A database URL without its password."""
    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import ArgumentError

    try:
        return make_url(url).render_as_string(hide_password=True)
    except (ArgumentError, ValueError):  # refused by db.urls.check, which hides a password
        return url


def engine_of(db: str | None) -> Engine:
    """:func:`existing_engine` of a command's ``--db`` (or ``RCB_DATABASE_URL`` without it)."""
    from api.settings import database_field, database_url

    return existing_engine(database_url(db), database_field(db))


def existing_engine(url: str, field: str = "--db") -> Engine:
    """An engine for an existing database migrated to this rcb's newest revision.

    Checked here, before a command uses it, so that each mistake is one line with its fix
    (:func:`db.urls.check`): a missing SQLite file is refused (not created), a server that does
    not answer is named by host and port, a database not migrated (or behind) asks for
    ``rcb db upgrade``. ``field`` names where the URL came from (``--db`` or
    ``RCB_DATABASE_URL``: :func:`api.settings.database_field`).
    """
    from db.engine import make_engine
    from db.urls import check

    parsed = check(url, field)
    if parsed.get_backend_name() == "sqlite" and not Path(parsed.database or "").is_file():
        reason = f"no such database file; create it: {_upgrade(url, field)}"
        raise InputError(field, shown(url), reason)
    engine = make_engine(url)
    try:
        _check_revision(engine, url, field)
    except BaseException:
        engine.dispose()
        raise
    return engine


def _check_revision(engine: Engine, url: str, field: str) -> None:
    """Refuse a database not at this rcb's newest revision, naming the command that fixes it."""
    from sqlalchemy.exc import DBAPIError

    from db.engine import HEAD_REVISION, revisions
    from db.urls import explain, revision, unknown_revision

    try:
        with engine.connect() as connection:
            found = revision(connection)
    except DBAPIError as err:
        reason = explain(err, url)
        if reason is None:
            raise
        raise InputError(field, shown(url), reason) from None
    if found == HEAD_REVISION:  # the usual case, without Alembic
        return
    known = revisions()
    if found is None:
        reason = f"the database is not migrated; run {_upgrade(url, field)}"
    elif found not in known:
        reason = unknown_revision(found)
    elif found != known[-1]:
        reason = f"the database is at revision {found}, not {known[-1]}; run {_upgrade(url, field)}"
    else:
        return
    raise InputError(field, shown(url), reason)


def _upgrade(url: str, field: str) -> str:
    """The command that migrates the database ``url`` named by ``field``."""
    return "rcb db upgrade" if field != "--db" else f"rcb db upgrade --db {shown(url)}"


def plan_of(engine: Engine, plan: str, option: str = "PLAN") -> int:
    """The id of a PLAN argument: digits are the id, anything else the plan's name.

    An unknown name: :class:`models.errors.InputError` naming ``option`` (the argument, or an
    option such as ``--plan``; one line, exit 2 in :func:`errors`).
    """
    from api.services.read.common import resolve_plan

    try:
        return resolve_plan(engine=engine, plan=plan)
    except InputError as err:
        raise InputError(option, plan, err.reason) from None


def check_target(path: Path, field: str = "--out") -> None:
    """Refuse an output path that cannot be a file, before doing any work."""
    if path.is_dir():
        raise InputError(field, str(path), "is a directory")
    if not path.parent.is_dir():
        raise InputError(field, str(path), "the directory does not exist")


def write_atomically(path: Path, data: bytes, field: str = "--out") -> None:
    """Write ``data`` to ``path`` whole or not at all (:mod:`api.cli.atomic`)."""
    with written_atomically(path, field) as file:
        file.write(data)


def number_cell(text: str, where: str) -> float:
    """A table cell as a finite number within :data:`models.bounds.LARGEST` in magnitude.

    ``where`` (``column[row]``) names it in errors.
    """
    cell = text.strip()
    if not cell:
        raise InputError(where, cell, "missing value")
    try:
        value = float(cell)
    except ValueError:
        raise InputError(where, cell, "must be a number") from None
    if not math.isfinite(value):
        raise InputError(where, cell, "must be a finite number")
    if abs(value) > LARGEST:
        raise InputError(where, cell, f"must be within ±{LARGEST:g}")
    return value
