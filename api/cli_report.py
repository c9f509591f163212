"""``rcb report PLAN --out report.html``: a plan's record as one self-contained HTML page.

The command reads the plan, its parts and its setpoint history with :mod:`api.queries` (the
parts before the history, so every version a part names is in the history read after it),
renders them with :func:`api.report_html.render_report` and writes the page atomically (a
temporary file in the same directory, then a rename): ``OUT`` is either the old file or the
whole new page, never half of one.

It only reads: it neither creates nor migrates a database (``rcb db upgrade`` does). Like
:mod:`api.cli_fit`, it does not import :mod:`api.cli` (which registers it); the error handling
of ``rcb`` is repeated in :func:`_errors`: bad input (an unknown plan, a database that cannot
be read, a path that cannot be written) is one line ``rcb: error: FIELD = VALUE: reason`` on
stderr and exit code 2, without a traceback.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from sqlalchemy import Engine
from sqlalchemy.engine import make_url
from sqlalchemy.exc import ArgumentError, DBAPIError

from api import queries
from api.service import NotFoundError
from db.engine import DEFAULT_URL, make_engine
from models.errors import InputError

_err = Console(stderr=True)


@contextmanager
def _errors() -> Iterator[None]:
    """Turn an :class:`InputError` into one line on stderr and exit code 2 (as ``rcb``)."""
    try:
        yield
    except InputError as err:
        _err.print(f"rcb: error: {err}", markup=False, highlight=False, soft_wrap=True)
        raise typer.Exit(2) from None


def _database_url(db: str | None) -> str:
    """``--db``, else ``$RCB_DATABASE_URL``, else the embedded default ``./rcb.db``."""
    return db or os.environ.get("RCB_DATABASE_URL") or DEFAULT_URL


def _shown(url: str) -> str:
    try:
        return make_url(url).render_as_string(hide_password=True)
    except ArgumentError:
        return url


def _engine(url: str) -> Engine:
    """An engine for an existing database (a missing SQLite file is not created)."""
    try:
        parsed = make_url(url)
    except ArgumentError as err:
        raise InputError("--db", url, f"not a database URL ({err})") from None
    database = parsed.database
    if parsed.get_backend_name() == "sqlite" and database not in (None, "", ":memory:"):
        if not Path(database).is_file():
            raise InputError("--db", _shown(url), "no such database file (rcb db upgrade)")
    try:
        return make_engine(url)
    except ArgumentError as err:  # also an unknown dialect or driver
        raise InputError("--db", _shown(url), f"cannot use this database ({err})") from None


def _no_table(message: str) -> bool:
    """Whether a database error says a table is missing (SQLite or PostgreSQL wording)."""
    return "no such table" in message or ('relation "' in message and "does not exist" in message)


def _read(engine: Engine, plan_id: int) -> tuple[dict[str, Any], dict[str, Any], list[Any]]:
    """The plan, its setpoint history and all its parts (oldest first)."""
    plan = queries.get_plan(engine=engine, plan_id=plan_id)
    parts: list[Any] = []
    cursor = None
    while True:
        page = queries.parts(engine=engine, plan_id=plan_id, cursor=cursor, limit=queries.MAX_PAGE)
        parts += page["items"]
        cursor = page["next_cursor"]
        if cursor is None:
            break
    history = queries.plan_history(engine=engine, plan_id=plan_id)
    return plan, history, parts


def _check_target(path: Path) -> None:
    """Refuse an output path that cannot be a file before doing any work."""
    if not path.parent.is_dir():
        raise InputError("--out", str(path), "the directory does not exist")
    if path.is_dir():
        raise InputError("--out", str(path), "is a directory")


def _umask() -> int:
    current = os.umask(0o022)
    os.umask(current)
    return current


def _write_atomically(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same directory."""
    temporary: str | None = None
    try:
        handle, temporary = tempfile.mkstemp(
            prefix=f".{path.name}.", suffix=".tmp", dir=path.parent
        )
        with os.fdopen(handle, "wb") as file:
            file.write(text.encode("utf-8"))
            file.flush()
            os.fsync(file.fileno())
        os.chmod(temporary, 0o666 & ~_umask())  # as a new file would be, not mkstemp's 0600
        os.replace(temporary, path)
    except OSError as err:
        if temporary is not None:
            with suppress(OSError):
                os.unlink(temporary)
        reason = err.strerror or err.__class__.__name__
        raise InputError("--out", str(path), f"cannot be written ({reason})") from None


def report(
    plan: Annotated[int, typer.Argument(metavar="PLAN", help="The plan's id (rcb plans).")],
    out: Annotated[
        Path,
        typer.Option("--out", help="The HTML file to write (replaced atomically if it exists)."),
    ],
    db: Annotated[
        str | None,
        typer.Option("--db", help="Database URL (default: $RCB_DATABASE_URL, else ./rcb.db)."),
    ] = None,
    last: Annotated[
        int | None,
        typer.Option(
            "--last",
            min=1,
            metavar="N",
            help="Plot only the last N parts; the tables keep them all.",
        ),
    ] = None,
) -> None:
    """Write a plan's record as one self-contained HTML page to mail (tables and plots).

    About 0.7 MB for the six operations of the demonstration part, plus about 6 kB per part
    plotted; --last N keeps the page of a long run small.
    """
    with _errors():
        _check_target(out)
        url = _database_url(db)
        engine = _engine(url)
        try:
            plan_data, history, parts = _read(engine, plan)
        except NotFoundError:
            raise InputError("PLAN", plan, f"no such plan in {_shown(url)}") from None
        except DBAPIError as err:
            first = str(err.orig or err).strip().splitlines()[0]
            hint = "; rcb db upgrade creates the tables" if _no_table(first) else ""
            raise InputError(
                "--db", _shown(url), f"cannot read this database ({first}){hint}"
            ) from None
        finally:
            engine.dispose()
        # imported here: matplotlib costs about 0.3 s, which no other rcb command should pay
        from api.report_html import render_report

        page = render_report(plan_data, history, parts, last=last)
        _write_atomically(out, page)
    size = len(page.encode("utf-8"))
    _err.print(
        f"rcb: wrote {out}: plan {plan} {plan_data['name']}, {len(parts)} parts, "
        f"{len(history['versions'])} setpoint versions, {size / 1000:.0f} kB",
        markup=False,
        highlight=False,
        soft_wrap=True,
    )
