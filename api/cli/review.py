"""Engineers' review at the command line: ``rcb plans``, ``history``, ``parts``.

``rcb export`` is :mod:`api.cli.export`.

Thin commands over :mod:`api.services.read` (the REST routes call the same), rich tables or
``--json``; every command takes ``--db URL``.
"""

from __future__ import annotations

import json
import shlex
import sys
from collections.abc import Iterable
from datetime import datetime
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.padding import Padding
from rich.table import Table
from rich.text import Text

from api.cli import parts_view
from api.cli.common import (
    DbOption,
    PlanArg,
    again_db,
    as_option,
    emit,
    engine_of,
    errors,
    plan_of,
    refused_line,
    say,
    say_command,
)
from api.cli.replan import CHANGE_OPTIONS
from api.cli.tables import free_text, new_table, short_number
from api.report import marks
from api.services import request_limits
from models.bounds import LARGEST_WHOLE
from models.errors import InputError

# Each command imports the queries (SQLAlchemy) and pandas when it runs: rcb --help and the
# other commands do not load them (README, "Speed").

_out = Console()

#: ``--json`` of the review commands (their help says less than :data:`api.cli.common.JsonOption`).
_JsonOption = Annotated[bool, typer.Option("--json", help="Print JSON.")]


def plans(
    ctx: typer.Context,
    limit: Annotated[
        int | None,
        typer.Option(help=f"Plans on the page (1-{request_limits.READ_PAGE}, default 100)."),
    ] = None,
    cursor: Annotated[str | None, typer.Option(help="Where the page starts (as printed).")] = None,
    db: DbOption = None,
    as_json: _JsonOption = False,
) -> None:
    """List plans by id and name: machine, RCB law, setpoint version in force, parts reported.

    A page, and how to get the next; ``--json`` without ``--limit`` streams every plan, one
    per line, a page at a time. ``rcb plans create FILE`` stores a plan, ``rcb plans show
    PLAN`` shows one; every PLAN argument takes a plan's id or its name.
    """
    if ctx.invoked_subcommand is not None:  # rcb plans create|show|list: that command's work
        return _refuse_before(
            ctx.invoked_subcommand, limit=limit, cursor=cursor, db=db, json=as_json
        )
    from api.services.read import plans as read_plans
    from api.services.read.common import LIST_PAGE

    with errors():
        engine = engine_of(db)
        size = _bounded("--limit", LIST_PAGE if limit is None else limit)
        try:
            page = read_plans.list_plans(engine=engine, cursor=cursor, page_size=size)
        except InputError as err:  # the option's name: --cursor
            raise as_option(err) from None
        if as_json:
            sys.stdout.write('{"plans": [')
            for n, p in enumerate(page["plans"]):
                sys.stdout.write((",\n" if n else "\n") + json.dumps(p, default=datetime.isoformat))
            while limit is None and page["next_cursor"] is not None:
                page = read_plans.list_plans(
                    engine=engine, cursor=page["next_cursor"], page_size=size
                )
                for p in page["plans"]:
                    sys.stdout.write(",\n" + json.dumps(p, default=datetime.isoformat))
            sys.stdout.write(f'\n], "next_cursor": {json.dumps(page["next_cursor"])}}}\n')
    if not as_json:
        _print_plans(page["plans"])
    if page["next_cursor"] is not None:
        again = f"rcb plans --cursor {page['next_cursor']} --limit {size}{again_db(db)}"
        say_command("rcb: next page:", again)


def _print_plans(listed: list[dict[str, Any]]) -> None:
    """A page of plans as a table, then each halted plan's conflicts."""
    table = new_table(title="plans")
    for column in ("id", "name", "machine", "RCB", "ver", "parts", "status", "created"):
        table.add_column(column, justify="right" if column in ("id", "ver", "parts") else "left")
    for name in table.columns[1:3]:  # a name's digit (lot-07, lathe-22kW) makes no number:
        free_text(name)  # a long name folds, not the headings (i / d, v / e / r) and dates
    for p in listed:
        halted = p["status"] == "halted"
        table.add_row(
            str(p["id"]),
            p["name"],
            p["machine"],
            f"{p['strategy']} α={p['alpha']:g}",
            str(p["setpoint_version"]),
            str(p["parts"]),
            "[bold red]HALTED[/]" if halted else _running(p),
            p["created_at"].strftime("%Y-%m-%d %H:%M"),
        )
    _out.print(table)
    for p in listed:
        if p["status"] == "halted":
            _print_halt(p["id"], p["halt"])
        if p.get("settings_refused"):
            say(refused_line(p["id"], p["settings_refused"]))


def _running(plan: dict[str, Any]) -> str:
    """A running plan's status: ``REFUSED`` when this version refuses its stored settings."""
    return "[bold yellow]REFUSED[/]" if plan.get("settings_refused") else "running"


def _refuse_before(command: str, **options: object) -> None:
    """Refuse an option of ``rcb plans`` given before its command (it would be ignored).

    ``rcb plans --db X show 1`` would read ./rcb.db: one line, exit 2.
    """
    for name, value in options.items():
        if value:
            with errors():
                where = f"rcb plans {command} ... --{name}"
                raise InputError(f"--{name}", value, f"goes after the command: {where}")


def _print_halt(plan_id: int, halt: dict[str, Any]) -> None:
    """A halted plan's conflicts, and how to resume it."""
    _out.print(f"[bold red]plan {plan_id} HALTED[/]: {marks.halt_cause(halt)}", highlight=False)
    for line in marks.halt_lines(halt):  # a long line (a gross breach's message) wraps indented
        _out.print(Padding(Text(line), (0, 0, 0, 2)), highlight=False)
    # any change resumes (--reason, --dry-run alone do not); 80 columns for a 10-digit id
    _out.print(f"  resume: rcb replan {plan_id} ({CHANGE_OPTIONS})", markup=False)


def history(
    plan: PlanArg,
    operation: Annotated[
        str | None, typer.Option(help="One operation in detail: setpoints, predictions, bands.")
    ] = None,
    last: Annotated[
        int, typer.Option(help=f"The newest N setpoint versions (1-{request_limits.READ_PAGE}).")
    ] = 50,
    before: Annotated[
        int | None,
        typer.Option(help="Only versions older than version V: the page before the one shown."),
    ] = None,
    db: DbOption = None,
    as_json: _JsonOption = False,
) -> None:
    """Setpoint versions with their cause, MRR and the RCB decisions behind each.

    The newest ``--last`` versions, or those before ``--before V``; a page that is not the
    first version says the command that shows the page before it.
    """
    from api.services.read import history as read_history
    from api.services.read import plan_parts as read_parts

    with errors():
        engine = engine_of(db)
        plan_key = plan_of(engine, plan)
        data = read_history.plan_history(
            engine=engine,
            plan_id=plan_key,
            cursor=_version_before(before),
            page_size=_bounded("--last", last),
            newest=True,
        )
        if not data["versions"]:  # only --before 1 asks for less than the first version
            raise InputError("--before", before, "no setpoint version is older")
        caused = [v["part_id"] for v in data["versions"] if v["part_id"] is not None]
        decisions = read_parts.decisions(engine=engine, plan_id=plan_key, part_ids=caused)
        names = [op["name"] for op in data["versions"][0]["operations"]]
        if operation is not None and operation not in names:
            raise InputError(
                "--operation", operation, f"not in the plan; known: {', '.join(names)}"
            )
    for version in data["versions"]:
        version["decisions"] = decisions.get(version["part_id"], [])
        if operation is not None:
            version["operations"] = [o for o in version["operations"] if o["name"] == operation]
    data["next_cursor"] = _version_after(data["next_cursor"])  # what --before takes
    if as_json:
        emit(data)
        return
    _out.print(_history_table(data, operation))
    if data["next_cursor"] is not None:
        kept = "" if operation is None else f" --operation {shlex.quote(operation)}"
        older = f"rcb history {plan} --before {data['next_cursor']}{kept}{again_db(db)}"
        _out.print(
            f"older versions: {older}", style="dim", markup=False, highlight=False, soft_wrap=True
        )
    if data["status"] == "halted":
        _print_halt(plan_key, data["halt"])


def _version_before(before: int | None) -> str | None:
    """``--before V`` as the history's cursor of ``order=newest``, None for the newest page.

    The user sees setpoint versions, not cursors: ``--before 29`` is the cursor ``"n29"``
    (:func:`api.services.read.common.ordered_cursor`).
    """
    from api.services.read.common import ordered_cursor

    if before is None:
        return None
    if not 1 <= before <= LARGEST_WHOLE:
        raise InputError("--before", before, f"a setpoint version is 1 to {LARGEST_WHOLE}")
    return ordered_cursor(before, newest=True)


def _version_after(cursor: str | None) -> str | None:
    """A ``next_cursor`` of ``order=newest`` as the version ``--before`` takes (``"n29"``: 29).

    None (the page reaches version 1) stays None.
    """
    from api.services.read.common import ordered_value

    return None if cursor is None else str(ordered_value(cursor, newest=True))


def _bounded(option: str, count: int) -> int:
    """``count`` if it is a page size the queries take; else an error naming ``option``."""
    if not 1 <= count <= request_limits.READ_PAGE:
        raise InputError(option, count, f"must be between 1 and {request_limits.READ_PAGE}")
    return count


def _history_table(data: dict[str, Any], operation: str | None) -> Table:
    """A row per setpoint version; with ``operation`` its setpoint, predictions and binding.

    One operation's table fits 80 columns with every word whole (a milling one too): the
    version heads its cause, the setpoint's names are short (``feed=0.3557``) and so are the
    parameters among the binding constraints (``feed``), a decision per line.
    """
    title = f"plan {data['plan_id']}: setpoint versions" + (f", {operation}" if operation else "")
    table = new_table(title=title)
    if operation is None:
        table.add_column("ver", justify="right")
        table.add_column("cause, when")
        table.add_column("cycle\nmin", justify="right")
        table.add_column("MRR cm³/min\nper operation")
    else:
        table.add_column("version,\ncause, when")
        table.add_column("setpoint")
        table.add_column("F N\n± band", justify="right")
        table.add_column("Ra µm\n± band", justify="right")
        table.add_column("MRR\ncm³/min", justify="right")
        table.add_column("binding")
    table.add_column("decisions")
    for v in data["versions"]:
        cause = v["cause"] + (f" {v['serial'] or v['actor'] or ''}").rstrip()
        when = f"{cause}\n{v['created_at'].strftime('%m-%d %H:%M:%S')}"
        moved = _decisions(v["decisions"], operation)
        if operation is None:
            mrr = " ".join(short_number(o["mrr_cm3_min"]) for o in v["operations"])
            table.add_row(str(v["version"]), when, short_number(v["cycle_time_min"]), mrr, moved)
        else:
            cells = _operation_cells(v["operations"][0])
            table.add_row(f"ver {v['version']}\n{when}", *cells, moved)
    return table


def _operation_cells(op: dict[str, Any]) -> list[str]:
    """One operation's setpoint, force and roughness with their bands, MRR, binding constraints.

    A cutting parameter is named by its first word (``feed=0.3557``, a binding ``feed``).
    """
    short = {k: k.split("_")[0] for k in op["setpoint"]}
    bands = [
        f"{short_number(op['predicted'][q]['value'])}\n±{short_number(op['predicted'][q]['band'])}"
        if q in op["predicted"]
        else "-"
        for q in ("force_N", "roughness_um")
    ]
    return [
        "\n".join(f"{short[k]}={short_number(x)}" for k, x in op["setpoint"].items()),
        *bands,
        short_number(op["mrr_cm3_min"]),
        "\n".join(short.get(b, b) for b in op["binding"]),
    ]


def _decisions(decisions: list[dict[str, Any]], operation: str | None) -> str:
    """The decisions that moved a band or carry a mark: a line per operation (``op: q action``).

    With ``operation`` only its own, a line each, without the operation's name.
    """
    lines: dict[str, list[str]] = {}
    for d in decisions:
        if (d["action"] != "hold" or marks.decision_mark(d)[0]) and (
            operation is None or d["operation"] == operation
        ):
            lines.setdefault(d["operation"], []).append(
                f"{d['quantity']} {d['action']}{_marked(d)}"
            )
    if operation is not None:
        return "\n".join(lines.get(operation, []))
    return "\n".join(f"{op}: {', '.join(moved)}" for op, moved in lines.items())


def _mark(d: dict[str, Any]) -> str:
    """A decision's mark in rich markup, ``""`` if none.

    ``BREACH``, ``ABOVE`` red; ``CHECK SENSOR: implausibly low`` black on yellow (the operator
    checks the sensor and the tool); ``note: below band`` dim.
    """
    label, kind = marks.decision_mark(d)
    if not label:
        return ""
    if kind == "note":
        return f"[dim]{label}[/]"
    if kind == "check":
        return f"[bold black on yellow]{label}[/]"
    return f"[bold red]{label}[/]"


def _marked(d: dict[str, Any]) -> str:
    """`` BREACH``, `` ABOVE``, `` CHECK SENSOR: …`` or `` (note: …)`` after a decision."""
    label, kind = marks.decision_mark(d)
    if not label:
        return ""
    return f" [dim]({label})[/]" if kind == "note" else f" {_mark(d)}"


def parts(
    plan: PlanArg,
    since: Annotated[
        str | None,
        typer.Option(help="Only parts received since an age (7d, 24h, 90m) or an ISO 8601 time."),
    ] = None,
    last: Annotated[
        int | None, typer.Option(help=f"Only the newest N parts (1-{request_limits.READ_PAGE}).")
    ] = None,
    db: DbOption = None,
    as_json: _JsonOption = False,
) -> None:
    """Parts with their measurements, the margins to each limit, and flagged violations.

    Reads and prints a page at a time: ``--json`` streams, memory does not grow with the plan.
    """
    from api.services.read import plan_parts as read_parts
    from api.services.read import plans as read_plans
    from api.services.since import since_of

    with errors():
        after = since_of(since)
        engine = engine_of(db)
        plan_key = plan_of(engine, plan)
        if last is not None:
            newest = read_parts.parts(
                engine=engine,
                plan_id=plan_key,
                page_size=_bounded("--last", last),
                newest=True,
                since=after,
            )
            pages: Iterable[list[dict[str, Any]]] = [newest["items"]]
        else:
            read_plans.get_plan(
                engine=engine, plan_id=plan_key
            )  # an unknown plan: one line, exit 2
            pages = read_parts.part_pages(engine=engine, plan_id=plan_key, since=after)
        if as_json:
            parts_view.stream_json(plan_key, pages)
            return
        title = f"plan {plan_key}: parts" + (f" since {since}" if since else "")
        shown = False
        for page in filter(None, pages):
            shown = True
            _out.print(parts_view.parts_table(title, page, short_number, _mark))
        if not shown:  # an empty table says nothing: say why the list is empty
            _out.print(f"{title}: none" + ("" if since else " reported yet"))
