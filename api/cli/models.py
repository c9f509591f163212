"""``rcb models export TOOL`` and ``rcb models import FILE``: learned models between plants.

A second plant's database starts where the first one is: its new plans with the tool start
from the first plant's learned models (``rcb plans create --prior fleet``) and its own.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from api.cli.common import DbOption, errors, existing_engine, read_json_file, say
from api.cli.who import ByOption, cli_actor
from models.errors import InputError

models_app = typer.Typer(
    help="A tool's learned models between databases (the fleet prior of a second plant).",
    no_args_is_help=True,
)


@models_app.command("export")
def export(
    tool: Annotated[str, typer.Argument(metavar="TOOL", help="The tool's name.")],
    out: Annotated[Path, typer.Option("--out", help="The JSON file to write.")],
    material: Annotated[
        str | None, typer.Option("--material", help="Only the models on this work material.")
    ] = None,
    db: DbOption = None,
) -> None:
    """Write TOOL's learned models (every learn plan's posterior, where it was learned)."""
    from api.services.fleet_models import export_tool
    from api.settings import database_field, database_url

    with errors():
        engine = existing_engine(database_url(db), database_field(db))
        data = export_tool(engine=engine, tool=tool, material=material)
        try:
            out.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
        except OSError as err:
            raise InputError("--out", str(out), f"cannot be written ({err.strerror})") from None
    say(f"rcb: {len(data['learned'])} learned models of {tool} written to {out}")


@models_app.command("import")
def import_(
    file: Annotated[Path, typer.Argument(metavar="FILE", help="A file rcb models export wrote.")],
    db: DbOption = None,
    by: ByOption = None,
) -> None:
    """Store the learned models of FILE (all or none): new plans with the tool start from them."""
    from api.services.fleet_models import import_tool
    from api.settings import database_field, database_url

    with errors():
        actor = cli_actor(by)
        data = read_json_file(file)
        engine = existing_engine(database_url(db), database_field(db))
        written = import_tool(engine=engine, data=data, source=file.name, actor=actor)
    say(imported_line(written.body, file.name))


def imported_line(body: dict[str, Any], name: str) -> str:
    """``rcb: 4 learned models stored from f.json (4 new)``, and what was not stored and why."""
    told = [f"{body['new']} new"] if body["new"] else []
    if body["replaced"]:
        told.append(f"{body['replaced']} replacing older exports of the same models")
    if body["kept"]:
        told.append(f"{body['kept']} already held, the same or with more readings")
    if body["own"]:
        told.append(f"{body['own']} learned by this database's own plans, skipped")
    said = "; ".join(told) or "none in it"
    return f"rcb: {body['stored']} learned models stored from {name} ({said})"
