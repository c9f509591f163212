"""A plan file as the commands that only read it take it (``rcb optimize``, ``rcb certify``).

They read it as ``rcb plans create`` does (:func:`supervisor.inputs.plan.plan_from_mapping`):
a tool is the file's own, else a stored one (``rcb tools add``) with ``--db`` or
``RCB_DATABASE_URL``, else the catalogue's. Without either no database is read (nor
``./rcb.db`` created), and an unknown tool says how to name a stored one.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from models.errors import InputError, InputErrors

if TYPE_CHECKING:
    from supervisor.inputs.plan import Plan

#: ``--db`` of a command that reads a plan file.
PlanToolsDbOption = Annotated[
    str | None,
    typer.Option(
        "--db",
        help="Take the stored tools the plan names from this database (rcb tools list;"
        " default: $RCB_DATABASE_URL when set, else the catalogue alone).",
        show_default=False,
    ),
]

#: What an unknown tool's error adds where no database was read.
STORED_HINT = "a stored tool: --db URL (rcb tools list)"


def file_plan(path: Path, db: str | None) -> Plan:
    """The plan of the file at ``path``, its tools looked up as above."""
    from api.settings import DATABASE_URL_VAR
    from supervisor.inputs.plan import load_plan, plan_from_mapping, read_plan

    if db is None and not os.environ.get(DATABASE_URL_VAR):
        try:
            return load_plan(path)
        except InputError as err:
            raise hinted(err) from None
    from api.cli.common import engine_of
    from api.services.read.tools import tools_of_plan

    body = read_plan(path)
    return plan_from_mapping(body, tools_of_plan(engine=engine_of(db), body=body))


def hinted(err: InputError) -> InputError:
    """``err`` with :data:`STORED_HINT` after each unknown tool it names."""
    if isinstance(err, InputErrors):
        return InputErrors([hinted(e) for e in err.errors])
    if err.reason.startswith("unknown tool"):
        return type(err)(err.field, err.value, f"{err.reason}; {STORED_HINT}")
    return err
