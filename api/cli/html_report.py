"""``rcb report PLAN --out report.html``: a plan's record as one self-contained HTML page.

The command reads what the page shows with :func:`api.services.read.record.report_record`: the last
``--last`` parts (default 100), the newest 200 setpoint versions (older ones summarised per 100
by the database) and the plan's totals as SQL aggregates, so the reads and the page stay the
same size whatever the plan's age. It renders them with
:func:`api.report.html.render_record` and writes the page atomically (a temporary file in the
same directory, then a rename): ``OUT`` is either the old file or the whole new page, never
half of one.

It only reads: it neither creates nor migrates a database (``rcb db upgrade`` does). Bad
input (an unknown plan, a database that cannot be read, a path that cannot be written) is one
line ``rcb: error: FIELD = VALUE: reason`` on stderr and exit code 2
(:func:`api.cli.common.errors`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from api.cli.common import (
    DbOption,
    PlanArg,
    check_target,
    errors,
    existing_engine,
    plan_of,
    say_filled,
    shown,
    write_atomically,
)
from api.services import request_limits
from api.services.errors import NotFoundError
from api.settings import database_field, database_url
from models.errors import InputError


def _no_table(message: str) -> bool:
    """Whether a database error says a table is missing (SQLite or PostgreSQL wording)."""
    return "no such table" in message or ('relation "' in message and "does not exist" in message)


def html_report(
    plan: PlanArg,
    out: Annotated[
        Path,
        typer.Option("--out", help="The HTML file to write (replaced atomically if it exists)."),
    ],
    db: DbOption = None,
    last: Annotated[
        int,
        typer.Option(
            "--last",
            min=1,
            max=request_limits.REPORT_MAX_LAST,
            metavar="N",
            help=(
                f"Plot and list the last N parts (1..{request_limits.REPORT_MAX_LAST});"
                " totals count all."
            ),
        ),
    ] = request_limits.REPORT_DEFAULT_LAST,
) -> None:
    """Write a plan's record as one self-contained HTML page to mail (tables and plots).

    About 115 kB for the six operations of the demonstration part with no part, 250 kB with
    the default 100 parts plotted, whatever the plan's age (docs/report.md).
    """
    # imported here (SQLAlchemy, NumPy): rcb --help and the other commands do not load them
    from sqlalchemy.exc import DBAPIError

    from api.services.read import record

    with errors():
        check_target(out)
        url = database_url(db)
        engine = existing_engine(url, database_field(db))
        try:
            plan_key = plan_of(engine, plan)
            data = record.report_record(engine=engine, plan_id=plan_key, last=last)
        except NotFoundError:
            raise InputError("PLAN", plan_key, f"no such plan in {shown(url)}") from None
        except DBAPIError as err:
            first = str(err.orig or err).strip().splitlines()[0]
            hint = "; rcb db upgrade creates the tables" if _no_table(first) else ""
            raise InputError(
                "--db", shown(url), f"cannot read this database ({first}){hint}"
            ) from None
        finally:
            engine.dispose()
        # the plots are drawn as SVG directly (api/report/svg.py): no matplotlib to import
        from api.report.html import render_record

        page = render_record(data)
        write_atomically(out, page.encode("utf-8"))
    size = len(page.encode("utf-8"))
    say_filled(
        f"rcb: wrote {out}: plan {plan_key} {data['plan']['name']}, {data['totals']['parts']} "
        f"parts ({len(data['parts'])} plotted), setpoint version "
        f"{data['history']['versions'][-1]['version']}, {size / 1000:.0f} kB"
    )
