"""``rcb report PLAN --out report.html``: a plan's record as one self-contained HTML page.

The command reads the plan, its parts and its setpoint history with :mod:`api.services.queries` (the
parts before the history, so every version a part names is in the history read after it),
renders them with :func:`api.report.html.render_html_report` and writes the page atomically (a
temporary file in the same directory, then a rename): ``OUT`` is either the old file or the
whole new page, never half of one.

It only reads: it neither creates nor migrates a database (``rcb db upgrade`` does). Bad
input (an unknown plan, a database that cannot be read, a path that cannot be written) is one
line ``rcb: error: FIELD = VALUE: reason`` on stderr and exit code 2
(:func:`api.cli.common.errors`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from sqlalchemy.exc import DBAPIError

from api.cli.common import (
    DbOption,
    check_target,
    errors,
    existing_engine,
    say,
    shown,
    write_atomically,
)
from api.services import queries
from api.services.errors import NotFoundError
from api.settings import database_url
from models.errors import InputError


def _no_table(message: str) -> bool:
    """Whether a database error says a table is missing (SQLite or PostgreSQL wording)."""
    return "no such table" in message or ('relation "' in message and "does not exist" in message)


def html_report(
    plan: Annotated[int, typer.Argument(metavar="PLAN", help="The plan's id (rcb plans).")],
    out: Annotated[
        Path,
        typer.Option("--out", help="The HTML file to write (replaced atomically if it exists)."),
    ],
    db: DbOption = None,
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
    with errors():
        check_target(out)
        url = database_url(db)
        engine = existing_engine(url)
        try:
            plan_data, history, parts = queries.record(engine=engine, plan_id=plan)
        except NotFoundError:
            raise InputError("PLAN", plan, f"no such plan in {shown(url)}") from None
        except DBAPIError as err:
            first = str(err.orig or err).strip().splitlines()[0]
            hint = "; rcb db upgrade creates the tables" if _no_table(first) else ""
            raise InputError(
                "--db", shown(url), f"cannot read this database ({first}){hint}"
            ) from None
        finally:
            engine.dispose()
        # imported here: matplotlib costs about 0.3 s, which no other rcb command should pay
        from api.report.html import render_html_report

        page = render_html_report(plan_data, history, parts, last=last)
        write_atomically(out, page.encode("utf-8"))
    size = len(page.encode("utf-8"))
    say(
        f"rcb: wrote {out}: plan {plan} {plan_data['name']}, {len(parts)} parts, "
        f"{len(history['versions'])} setpoint versions, {size / 1000:.0f} kB"
    )
