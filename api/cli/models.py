"""``rcb models export TOOL`` and ``rcb models import FILE``: learned models between plants.

A second plant's database starts where the first one is: its new plans with the tool start
from the first plant's learned models (``rcb plans create --prior fleet``) and its own.
"""

from __future__ import annotations

import json
import textwrap
from pathlib import Path
from typing import Annotated, Any

import typer

from api.cli.common import (
    DbOption,
    JsonOption,
    emit,
    engine_of,
    errors,
    say,
    write_atomically,
)
from api.cli.who import ByOption, cli_actor
from models.bounds import MAX_MODELS_BYTES
from models.errors import InputError
from supervisor.inputs.files import read_json

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
    as_json: JsonOption = False,
) -> None:
    """Write TOOL's learned models in the fleet: what new plans' fleet priors start from.

    Of each machine, its 10 newest learn plans with the tool that learned a model of it,
    neither halted nor taken out (rcb fleet exclude) nor with a change of process not yet
    accepted (rcb fleet include): this database's plans and, counted the same way, the models
    it imported from other databases. Each model names the database that learned it. rcb
    fleet show TOOL lists the plans, and why one is out.
    """
    from api.services.fleet_models import export_tool

    with errors():
        engine = engine_of(db)
        data = export_tool(engine=engine, tool=tool, material=material)
        text = json.dumps(data, indent=1) + "\n"
        if len(text) > MAX_MODELS_BYTES:  # compact, as an import may have read it (a review)
            text = json.dumps(data, separators=(",", ":")) + "\n"
        size = len(text.encode("utf-8"))
        if size > MAX_MODELS_BYTES:  # what import would refuse is not written
            raise InputError(
                "TOOL",
                tool,
                f"its {len(data['learned'])} learned models make {size} bytes, more than rcb"
                f" models import reads ({MAX_MODELS_BYTES}); export one --material at a time",
            )
        write_atomically(out, text.encode("utf-8"))  # a failed write leaves ``out`` as it was
    if as_json:  # the document is in the file: what was written, and where
        emit(
            {
                "tool": tool,
                "material": data["material"],
                "learned": len(data["learned"]),
                "out": str(out),
                "bytes": size,
            }
        )
    else:
        say(f"rcb: {len(data['learned'])} learned models of {tool} written to {out}")


@models_app.command("import")
def import_(
    file: Annotated[Path, typer.Argument(metavar="FILE", help="A file rcb models export wrote.")],
    db: DbOption = None,
    by: ByOption = None,
    as_json: JsonOption = False,
) -> None:
    """Store the learned models of FILE (all or none): new plans with the tool start from them."""
    from api.services.fleet_models import import_tool

    with errors():
        actor = cli_actor(by)
        data = read_json(file, "FILE", MAX_MODELS_BYTES)
        engine = engine_of(db)
        written = import_tool(engine=engine, data=data, source=file.name, actor=actor)
    if as_json:
        emit(written.body)
    else:
        say(imported_line(written.body, file.name))


@models_app.command("identity")
def identity(
    renew: Annotated[
        bool,
        typer.Option(
            "--renew",
            help="Give this database a new identity (a copy of another database's; its plans"
            " keep the old one).",
        ),
    ] = False,
    db: DbOption = None,
    by: ByOption = None,
    as_json: JsonOption = False,
) -> None:
    """The identity this database's exports name as their models' origin."""
    from api.services import fleet_models

    with errors():
        actor = cli_actor(by)
        engine = engine_of(db)
        if renew:
            body = fleet_models.renew_identity(engine=engine, actor=actor).body
        else:
            body = fleet_models.identity(engine=engine)
    if as_json:
        emit(body)
    elif renew:
        say(f"rcb: this database's identity is now {body['identity']}")
        say(f"rcb: (was {body['was']}, which its {body['plans_keeping_it']} plans keep)")
    else:
        say(f"rcb: this database's identity is {body['identity']}")
        for origin, count in body["inherited"].items():
            say(f"rcb: {count} of its plans were created under {origin}")


def imported_line(body: dict[str, Any], name: str) -> str:
    """``rcb: 4 learned models stored from f.json (4 new)``, and what was not stored and why."""
    told = [f"{body['new']} new"] if body["new"] else []
    if body["replaced"]:
        told.append(f"{body['replaced']} replacing older exports of the same models")
    if body["kept"]:
        told.append(f"{body['kept']} already held, the same or with more readings")
    if body["own"]:
        told.append(f"{body['own']} learned by plans this database holds, skipped")
    said = "; ".join(told) or "none in it"
    line = f"rcb: {body['stored']} learned models stored from {name} ({said})"
    line = textwrap.fill(line, width=80, subsequent_indent="  ", break_on_hyphens=False)
    if body.get("copied"):
        line += (
            f"\nrcb: {body['copied']} of them carry this database's identity but plans it does"
            f" not hold:\nrcb: one of {name}'s database and this one is a copy of the other;"
            "\nrcb: give the copy an identity of its own: rcb models identity --renew"
        )
    return line
