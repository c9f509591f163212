"""``rcb tools list``, ``show`` and ``add``: the tool library a plan's operations name.

The packaged catalogue and the database's stored tools, as ``GET /tools`` and ``POST /tools``
serve them to the MES. A stored tool never changes (``POST /tools``); one a later version's
check refuses is listed as stored, marked, with the way out: define it anew under another
name, which ``rcb tools add`` does from a file.
"""

from __future__ import annotations

import json
import sys
import textwrap
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console

from api.cli.common import (
    DbOption,
    JsonOption,
    again_db,
    as_option,
    emit,
    engine_of,
    errors,
    say,
    say_command,
)
from api.cli.tables import fmt, new_table
from api.cli.who import ByOption, cli_actor
from api.services import request_limits
from models.errors import InputError

tools_app = typer.Typer(
    help="The tool library: the catalogue and the stored tools plans name.",
    no_args_is_help=True,
)
NameArg = Annotated[str, typer.Argument(metavar="NAME", help="The tool's name.")]


@tools_app.command("list")
def list_(
    limit: Annotated[
        int, typer.Option(help=f"Tools on the page (1-{request_limits.READ_PAGE}).")
    ] = 100,
    cursor: Annotated[
        str | None, typer.Option(help="Where the page starts (as printed).", show_default=False)
    ] = None,
    db: DbOption = None,
    as_json: JsonOption = False,
) -> None:
    """The catalogue's and the database's tools by name, a page at a time."""
    from api.services.read.tools import list_tools

    with errors():
        engine = engine_of(db)
        try:
            page = list_tools(engine=engine, cursor=cursor, page_size=limit)
        except InputError as err:  # page_size, cursor: the options' names
            raise as_option(err) from None
    if as_json:  # on stdout, the messages on stderr: a pipe reads the JSON alone
        sys.stdout.write(json.dumps(page) + "\n")
        return
    table = new_table(title="tools (rcb tools show NAME: the models)")
    for column in ("name", "process", "material", "models", "source"):
        table.add_column(column)
    for tool in page["tools"]:
        name = tool["name"] + ("\nREFUSED" if tool.get("refused") else "")
        models = "\n".join(tool["models"])
        table.add_row(name, tool["process"], tool["material"], models, tool["source"])
    Console().print(table)
    if any(tool.get("refused") for tool in page["tools"]):
        say("rcb: REFUSED: this version's check refuses a stored value (rcb tools show NAME)")
    if page["next_cursor"] is not None:
        again = f"rcb tools list --cursor {page['next_cursor']} --limit {limit}{again_db(db)}"
        say_command("rcb: next page:", again)


@tools_app.command("show")
def show(name: NameArg, db: DbOption = None, as_json: JsonOption = False) -> None:
    """One tool: each model's K, band dK and exponents, with their provenance."""
    from api.services.errors import NotFoundError
    from api.services.read.tools import get_tool

    with errors():
        engine = engine_of(db)
        try:
            tool = get_tool(engine=engine, name=name)
        except NotFoundError:
            known = "no such tool in the catalogue or the database"
            raise InputError("NAME", name, known) from None
    if as_json:
        emit(tool)
        return
    Console().print(_models_table(tool))
    told = [(key, tool[key]) for key in ("description", "material", "source") if tool[key]]
    if tool.get("refused"):
        told.append(("REFUSED", tool["refused"]))
    for key, text in told:  # within 80 columns, as a terminal shows them
        say(textwrap.fill(f"rcb: {key}: {text}", width=80, subsequent_indent="  "))


def _models_table(tool: dict[str, Any]) -> Any:
    table = new_table(title=f"{tool['name']} ({tool['process']}): Y = K · Π x^e, K ± dK")
    for column in ("quantity", "K", "dK", "dK %", "exponents", "reference"):
        table.add_column(column, justify="right" if column in ("K", "dK", "dK %") else "left")
    for quantity, model in tool["models"].items():
        exponents = "\n".join(f"{x}={fmt(e)}" for x, e in model["exponents"].items())
        relative = f"{100 * model['dK'] / model['K']:.1f}" if model["K"] > 0 else "-"
        table.add_row(
            quantity,
            fmt(model["K"]),
            fmt(model["dK"]),
            relative,
            exponents,
            model["reference"] or model["source"],
        )
    return table


@tools_app.command("add")
def add(
    file: Annotated[
        Path,
        typer.Argument(
            metavar="FILE",
            help="One tool: name, process, models (TOML, or JSON as POST /tools takes); a "
            "plan file's [[tools]] block of one tool is taken as that tool.",
        ),
    ],
    db: DbOption = None,
    by: ByOption = None,
) -> None:
    """Store a new tool with its baseline models; plans then name it (stored tools never change)."""
    from api.services.tools import add_tool

    with errors():
        actor = cli_actor(by)
        body = read_tool_file(file)
        body.setdefault("source", file.name)
        engine = engine_of(db)
        written = add_tool(engine=engine, body=body, actor=actor)
    models = ", ".join(written.body["models"])
    say(f"rcb: tool {written.body['name']} stored with its models of {models}")


def read_tool_file(path: Path) -> dict[str, Any]:
    """A tool file's table: TOML, or ``.json`` as ``POST /tools`` takes it (errors name FILE).

    A plan file's ``[[tools]]`` block of one tool, copied whole, is taken as that tool: the same
    table, one level down. Several tools (a file each), or a whole plan file, are refused in
    one short line (before: the whole list echoed as an unknown field of a tool).
    """
    from supervisor.inputs.files import read_document

    data = read_document(path, "FILE")
    if not isinstance(data, dict):
        raise InputError("FILE", str(path), "must hold a tool (a table of name, process, models)")
    tools = data.get("tools")
    if not isinstance(tools, list):
        if {"machine", "operations"} & set(data):  # a plan file naming catalogue tools only
            raise InputError(
                "FILE", str(path), "is a plan file, not a tool (name, process, models)"
            )
        return data
    if set(data) == {"tools"} and len(tools) == 1 and isinstance(tools[0], dict):
        return tools[0]
    if set(data) != {"tools"}:  # a whole plan file
        raise InputError("FILE", str(path), "is a plan file, not a tool (name, process, models)")
    raise InputError(
        "FILE", str(path), f"holds {len(tools)} tools; a tool file holds one (a file each)"
    )
