"""``rcb fleet show``, ``law``, ``imported``, ``exclude``, ``include``: new plans' priors.

A plan or a machine an engineer takes out no longer counts in any new plan's prior (a machine
with a loose spindle, a plan cut on the wrong material); a plan whose process changed is out
by itself until an engineer puts it back, which accepts the changes it counted so far.
"""

from __future__ import annotations

import json
import re
import sys
import textwrap
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

from api.cli.common import (
    WIDTH,
    DbOption,
    JsonOption,
    again_db,
    as_option,
    emit,
    engine_of,
    errors,
    plan_of,
    say,
    say_command,
    say_error,
    say_filled,
)
from api.cli.tables import fmt, new_table
from api.cli.who import ByOption, cli_actor
from api.services import request_limits

fleet_app = typer.Typer(
    help="Which plans and machines make new plans' fleet priors (learn's start).",
    no_args_is_help=True,
)

PlanOption = Annotated[
    str | None, typer.Option("--plan", help="A plan, by id or name.", show_default=False)
]
CursorOption = Annotated[
    str | None, typer.Option(help="Where the page starts (as printed).", show_default=False)
]
MachineOption = Annotated[
    str | None, typer.Option("--machine", help="A machine, by name.", show_default=False)
]


@fleet_app.command("show")
def show(
    tool: Annotated[str, typer.Argument(help="The tool, by name.", show_default=False)],
    limit: Annotated[
        int, typer.Option(help=f"Plans on the page (1-{request_limits.READ_PAGE}).")
    ] = 100,
    cursor: CursorOption = None,
    newest: Annotated[
        bool,
        typer.Option(
            "--newest",
            help="Newest plans first: each machine's newest, those in the fleet, come first.",
        ),
    ] = False,
    db: DbOption = None,
    as_json: JsonOption = False,
) -> None:
    """The plans using TOOL: in the fleet or why not, readings, priors let go."""
    from api.services.read.fleet import fleet_members

    _same_order(cursor, newest)
    page = _read(fleet_members, tool, db, cursor=cursor, page_size=limit, newest=newest)
    if as_json:  # on stdout, the messages on stderr: a pipe reads the JSON alone
        sys.stdout.write(json.dumps(page) + "\n")
        return
    _print_members(page, first=cursor is None, db=db)
    if page["next_cursor"] is not None:
        again = f"rcb fleet show {tool} --cursor {page['next_cursor']} --limit {limit}"
        again += " --newest" * newest + again_db(db)
        say_command("rcb: next page:", again)


def _same_order(cursor: str | None, newest: bool) -> None:
    """Refuse a ``--cursor`` of the other order, in this command's words (not REST's)."""
    from models.errors import InputError

    digits = (cursor or "").removeprefix("n")
    if cursor is None or not digits.isdigit() or cursor.startswith("n") == newest:
        return
    made = "with --newest" if cursor.startswith("n") else "without --newest"
    with errors():
        raise InputError("--cursor", cursor, f"continues a page made {made}: send it so")


@fleet_app.command("law")
def law(
    tool: Annotated[str, typer.Argument(help="The tool, by name.", show_default=False)],
    db: DbOption = None,
    as_json: JsonOption = False,
) -> None:
    """What the fleet learned of TOOL's law: K, exponents and spreads beside the catalogue."""
    from api.services.read.fleet import fleet_law

    found = _read(fleet_law, tool, db)
    if as_json:
        sys.stdout.write(json.dumps(found) + "\n")
        return
    for quantity in found["quantities"]:
        _print_law(tool, quantity)
    if not found["quantities"]:
        say(f"rcb: no plan in the fleet measured {tool}: new plans start from the catalogue")


def _print_law(tool: str, q: dict[str, Any]) -> None:
    """One quantity's law: the fleet's and the catalogue's parameters, then where it is known.

    The point of the last line is where the machines' readings pin the law best
    (:func:`supervisor.fleet.hierarchy.best_determined`), not where any machine cut.
    """
    console = Console()
    _print_filled(console, f"{tool} {q['text']}")
    table = new_table("parameter", "fleet", "catalogue")  # a value and its sd: words that wrap
    table.add_row("K", fmt(q["K"]), fmt(q["catalogue_K"]))
    for p in q["parameters"]:
        row = ((p["fleet"], p["fleet_sd"]), (p["catalogue"], p["catalogue_sd"]))
        if p["name"] == "edge_rise":  # of ln Y over an edge's life: a fraction of Y
            # + 0.0: a rise of -0.004 % is shown as 0.0 %, not -0.0 %
            cells = [f"{round(100 * v, 1) + 0.0:.1f} % ± {100 * sd:.1f} %" for v, sd in row]
            table.add_row("rise over an edge", *cells)
        else:
            table.add_row(p["name"], *(f"{fmt(v)} ± {sd:.2g}" for v, sd in row))
    console.print(table)
    where = ", ".join(f"{name}{NBSP}{fmt(value)}" for name, value in q["reference"].items())
    _print_filled(
        console,
        f"Where the machines' readings pin the law best ({where}), on a new edge, Y is known "
        f"to ± {100 * q['law_sd']:.1f} %, a new machine's to ± {100 * q['new_machine_sd']:.1f} "
        f"%, the catalogue's to ± {100 * q['catalogue_sd']:.1f} % (1 sd).",
    )
    console.print()


#: A no-break space: joins what a line may not end between (textwrap breaks at ASCII spaces).
NBSP = "\u00a0"
#: ``± 2.9`` and ``2.9 %``: a number with its sign and its unit, kept on one line.
_TOGETHER = re.compile(r"(?<=±) (?=[0-9])|(?<=[0-9]) (?=%)")


def _print_filled(console: Console, text: str) -> None:
    """``text`` filled to the console's width (80 at most), never between a number and its unit.

    ``± 2.9 %`` and ``depth_mm 2.988`` stay whole; rich alone wraps at any space (``spread
    4.1`` at a line's end, ``%,`` on the next).
    """
    filled = _filled(text, min(console.width, WIDTH))
    console.print(filled, markup=False, highlight=False, soft_wrap=True)


def _filled(text: str, width: int = WIDTH, indent: str = "") -> str:
    """``text`` filled to ``width``, not broken at a no-break space nor inside ``± 2.9 %``."""
    joined = _TOGETHER.sub(NBSP, text)
    filled = textwrap.fill(
        joined,
        width=width,
        subsequent_indent=indent,
        break_on_hyphens=False,
        break_long_words=False,
    )
    return filled.replace(NBSP, " ")


@fleet_app.command("imported")
def imported(
    tool: Annotated[str, typer.Argument(help="The tool, by name.", show_default=False)],
    limit: Annotated[
        int, typer.Option(help=f"Machines on the page (1-{request_limits.READ_PAGE}).")
    ] = 100,
    cursor: CursorOption = None,
    db: DbOption = None,
    as_json: JsonOption = False,
) -> None:
    """The machines of TOOL's imported models, by the names to take them out by."""
    from api.services.read.fleet import imported_fleet

    page = _page(imported_fleet, tool, cursor, limit, db)
    if as_json:
        sys.stdout.write(json.dumps(page) + "\n")
        return
    if page["machines"]:  # none: the sentence alone, no empty table
        table = new_table(title=f"{tool}: machines of the models imported from other databases")
        for column in ("machine", "models", "readings", "in the fleet"):
            right = column in ("models", "readings")
            table.add_column(column, justify="right" if right else "left")
        for m in page["machines"]:
            fleet = "yes" if m["in_fleet"] else f"no: {m['out']}"
            table.add_row(m["machine"], str(m["models"]), str(m["readings"]), fleet)
        Console().print(table)
    elif cursor is None:
        say(f"rcb: no model of {tool} was imported (rcb models import FILE)")
    if page["next_cursor"] is not None:
        again = f"rcb fleet imported {tool} --cursor {page['next_cursor']} --limit {limit}"
        again += again_db(db)
        say_command("rcb: next page:", again)


def _page(
    fetch: Callable[..., dict[str, Any]], tool: str, cursor: str | None, limit: int, db: str | None
) -> dict[str, Any]:
    """A page of ``fetch``: the options' names in its errors, an unknown tool named."""
    return _read(fetch, tool, db, cursor=cursor, page_size=limit)


def _read(
    fetch: Callable[..., dict[str, Any]], tool: str, db: str | None, **options: Any
) -> dict[str, Any]:
    """``fetch`` of ``tool``: its options named in its errors, an unknown tool named."""
    from api.services.errors import NotFoundError
    from models.errors import InputError

    with errors():
        engine = engine_of(db)
        try:
            found = fetch(engine=engine, tool=tool, **options)
        except InputError as err:  # limit, cursor: the options' names
            raise as_option(err) from None
        except NotFoundError:
            raise InputError(
                "TOOL", tool, "no such tool in the catalogue or the database"
            ) from None
    return found


def _print_members(page: dict[str, Any], first: bool, db: str | None) -> None:
    """The page's plans (no table where there are none), then what else holds the tool.

    The commands it prints to run next read the same database (``--db``, :func:`again_db`).
    """
    tool = page["tool"]
    if page["plans"]:
        Console().print(_members_table(page))
    if not first:
        return
    imported, in_fleet = page["imported"], page["imported_in_fleet"]
    if not page["plans"]:  # the imported models of machines taken out make no prior
        start = "the imported models" if in_fleet else "the catalogue"
        say_filled(f"rcb: no stored plan uses {tool}: new plans start from {start}")
    if imported:  # the command whole, to copy
        text = f"rcb: and {imported} learned models imported from other databases"
        command = f"rcb fleet imported {tool}{again_db(db)}"
        if in_fleet < imported:  # some machines taken out: the sentence filled to 80
            say_filled(f"{text} ({in_fleet} of them in the fleet); their machines:")
            say(f"  {command}")
        else:
            say_command(f"{text}; their machines:", command)
    if any(not m["out"] for m in page["plans"]):
        say_command("rcb: what they learned of its law:", f"rcb fleet law {tool}{again_db(db)}")


def _members_table(page: dict[str, Any]) -> Table:
    table = new_table(title=f"{page['tool']}: the plans using it")
    for column in ("id", "plan", "machine", "readings", "in the fleet"):
        table.add_column(column, justify="right" if column in ("id", "readings") else "left")
    for m in page["plans"]:
        fleet = "yes" if not m["out"] else f"no: {m['out']}"
        if m["let_go"]:
            fleet += f"; prior let go: {', '.join(m['let_go'])}"
        table.add_row(str(m["plan_id"]), m["plan"], m["machine"], str(m["readings"]), fleet)
    return table


@fleet_app.command("exclude")
def exclude(
    reason: Annotated[str, typer.Option("--reason", help="Why, one line (kept with it).")],
    plan: PlanOption = None,
    machine: MachineOption = None,
    db: DbOption = None,
    by: ByOption = None,
    as_json: JsonOption = False,
) -> None:
    """Take a plan (--plan) or every plan of a machine (--machine) out of the fleet."""
    from api.services.fleet_models import exclude_from_fleet
    from db.fleet_exclusions import one_of

    with errors():
        one_of(plan, machine)  # before the plan is looked up: say both, not a name's error
        actor = cli_actor(by)
        engine = engine_of(db)
        plan_id = None if plan is None else plan_of(engine, plan, "--plan")
        with _as_typed(plan):
            done = exclude_from_fleet(
                engine=engine, plan_id=plan_id, machine=machine, reason=reason, actor=actor
            )
    if as_json:
        emit(done.body)
    else:
        say_filled(_excluded(done.body))


def _excluded(body: dict[str, Any]) -> str:
    """What ``exclude`` did: taken out, or already out and only its reason changed."""
    target, reason, was = body["excluded"], body["reason"], body.get("was")
    if was is None:
        return f"rcb: {target} is out of the fleet ({reason})"
    return f"rcb: {target} was already out of the fleet ({was}); its reason is now: {reason}"


@fleet_app.command("include")
def include(
    plan: PlanOption = None,
    machine: MachineOption = None,
    changes: Annotated[
        int | None,
        typer.Option(
            "--changes",
            help="The plan's changes not accepted you reviewed (as shown: '2 not accepted');"
            " refused if it has another count now.",
            show_default=False,
        ),
    ] = None,
    reason: Annotated[
        str | None,
        typer.Option("--reason", help="Why, one line (kept in the audit log).", show_default=False),
    ] = None,
    db: DbOption = None,
    by: ByOption = None,
    as_json: JsonOption = False,
) -> None:
    """Put a plan or a machine back in the fleet (a plan's changes so far accepted)."""
    from api.services.fleet_models import include_in_fleet
    from db.fleet_exclusions import one_of

    with errors():
        one_of(plan, machine)
        actor = cli_actor(by)
        engine = engine_of(db)
        plan_id = None if plan is None else plan_of(engine, plan, "--plan")
        with _as_typed(plan):
            done = include_in_fleet(
                engine=engine,
                plan_id=plan_id,
                machine=machine,
                changes=changes,
                reason=reason,
                actor=actor,
            )
    if as_json:
        emit(done.body)
    else:
        say_filled(_included(done.body))


def _included(body: dict[str, Any]) -> str:
    """What ``include`` did: put back, nothing to put back, and what keeps the plan out."""
    target, still = body["included"], body["still_out"]
    if target.startswith("machine ") and still:  # the machine is in; some of its plans are not
        done = "is back in the fleet" if body["put_back"] else "is not taken out of the fleet"
        return f"rcb: {target} {done}, but {still}"
    if not body["put_back"]:
        itself = " itself" if still else ""
        text = f"rcb: {target} is not taken out of the fleet{itself}: nothing to put back"
        return f"{text}; it stays out: {still}" if still else text
    accepted = body["changes_accepted"]
    changes = f"{accepted} change{'' if accepted == 1 else 's'} of its process accepted"
    if still:
        extra = f" ({changes})" if accepted else ""
        return f"rcb: {target} is put back{extra}, but stays out of the fleet: {still}"
    extra = f"; {changes}" if accepted else ""
    return f"rcb: {target} is back in the fleet{extra}"


@contextmanager
def _as_typed(plan: str | None) -> Iterator[None]:
    """The use case's error in 80 columns, a ``--plan`` one with the plan as typed.

    ``--plan = 'vl-f'`` for a name, the id for digits; exit 2, as :func:`errors` does.
    """
    from models.errors import InputError

    try:
        yield
    except InputError as err:
        if err.field == "--plan" and plan is not None and not plan.isdigit():
            err = InputError("--plan", plan, err.reason)
        say_error(f"rcb: error: {err}")
        raise typer.Exit(2) from None
