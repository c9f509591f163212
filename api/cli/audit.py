"""``rcb audit``: who did what to the database, and when, newest first.

Every write over REST or at the CLI, every refused key, every fleet verdict and halt (actor
``rcb``) and every pruning is in the audit log (``audit_log``). This is its reader: a page at
a time, optionally of one action, one actor, one plan, from a time on
(api/services/audit_log.py).
"""

from __future__ import annotations

import json
import shlex
from http import HTTPStatus
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console, ConsoleOptions, RenderResult
from rich.padding import Padding
from rich.segment import Segment
from rich.text import Text

from api.cli.common import DbOption, again_db, emit, engine_of, errors, say_command
from api.cli.tables import free_text, new_table
from api.services import request_limits
from models.errors import InputError

if TYPE_CHECKING:
    from sqlalchemy import Engine

_out = Console()


def audit(
    action: Annotated[
        str | None,
        typer.Option(
            help="Only this action, e.g. 'replan', 'fleet exclude', 'report part', 'halt'."
        ),
    ] = None,
    actor: Annotated[
        str | None,
        typer.Option(help="Only this actor, e.g. 'cli:ana', 'key:3', 'rcb', 'anonymous'."),
    ] = None,
    since: Annotated[
        str | None,
        typer.Option(help="Only entries this recent (7d, 24h, 90m) or at or after an ISO time."),
    ] = None,
    plan: Annotated[
        str | None,
        typer.Option(
            help="Only entries about this plan (id or name): its creation, part reports, "
            "replans, fleet exclusions and verdicts, and its machine's fleet exclusions "
            "and inclusions (rcb fleet exclude --machine)."
        ),
    ] = None,
    limit: Annotated[
        int, typer.Option(help=f"Entries per page (1 to {request_limits.READ_PAGE}).")
    ] = 50,
    cursor: Annotated[str | None, typer.Option(help="Where the page starts (as printed).")] = None,
    db: DbOption = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """The audit log, newest first: when, who, what, on what, the result and its detail.

    A page, and how to get the next (older) one with the same filters.
    """
    from api.services.audit_log import audit_page, query_of

    with errors():
        engine = engine_of(db)
        plan_id = None if plan is None else _plan_id(engine, plan)
        query = query_of(action, actor, since, plan_id)
        page = audit_page(engine=engine, query=query, cursor=cursor, limit=limit)
    if as_json:
        emit(page)
    else:
        _out.print(_Entries(page["entries"]))
    if page["next_cursor"] is not None:
        again = [("--action", action), ("--actor", actor), ("--since", since), ("--plan", plan)]
        kept = "".join(f" {name} {shlex.quote(value)}" for name, value in again if value)
        again_command = f"rcb audit{kept} --cursor {page['next_cursor']} --limit {limit}"
        again_command += again_db(db)
        say_command("rcb: older entries:", again_command)


def _plan_id(engine: Engine, plan: str) -> int:
    """``--plan``: a stored plan's id or name, or an id the audit log is about (exit 2 if none)."""
    from api.services.read.common import resolve_audited_plan

    try:
        return resolve_audited_plan(engine=engine, plan=plan)
    except InputError as err:
        raise InputError("--plan", plan, err.reason) from None


#: The longest actor, action, target or result word the audit table keeps on one line.
NAME_KEPT = 24
#: Where an entry's detail starts, under its row.
DETAIL_INDENT = 4


class _Entries:
    """The entries' table (when, who, what, on what, the result), each one's detail under it.

    The detail is as wide as the console: it is the longest cell (a refusal's message, a wrong
    key's window), and as a sixth column it had 15 of 80 columns, a refusal 11 lines. Text as
    stored, never markup. The table draws a line between its rows (``show_lines``; blank in
    its box), so each blank line after the heading rule ends the row above it. A console so
    narrow that a row's time folds onto a blank line of its own makes more of them than
    rows: each entry is then a table of its own, unaligned, never an error.
    """

    def __init__(self, entries: list[dict[str, Any]]) -> None:
        self.entries = entries

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> RenderResult:
        lines = console.render_lines(_table(self.entries), options, pad=False)
        plain = ["".join(segment.text for segment in line).strip() for line in lines]
        rule = next(i for i, text in enumerate(plain) if text and not text.strip("─"))
        between = [i for i in range(rule + 1, len(lines)) if not plain[i]]
        for line in lines[: rule + 1]:  # the title, headings, rule
            yield from (*line, Segment.line())
        starts, ends = [rule, *between], [*between, len(lines)]
        if len(starts) != len(self.entries):
            rows = [
                console.render_lines(_table([e], heading=False), options, pad=False)
                for e in self.entries
            ]
            starts, ends = [-1] * len(rows), [len(row) for row in rows]
        else:
            rows = [lines] * len(self.entries)
        for entry, row, first, last in zip(self.entries, rows, starts, ends, strict=True):
            for line in row[first + 1 : last]:
                yield from (*line, Segment.line())
            detail = _detail(entry["detail"])
            if detail:
                yield Padding(Text(detail, overflow="fold"), (0, 0, 0, DETAIL_INDENT))


def _table(entries: list[dict[str, Any]], heading: bool = True) -> Any:
    """The entries' rows without their detail (text as stored, never markup).

    ``heading``: with the title and the headings (else the rows alone).
    """
    entries = [{**entry, "result": said(entry["result"])} for entry in entries]
    table = new_table(
        *("at (UTC)", "actor", "action", "target", "result"),
        title="audit" if heading else None,
        show_header=heading,
        show_lines=True,
    )
    # the time on one line, folded as late as the headings (entries are scanned by it)
    free_text(table.columns[0], kept=len("2026-12-05 01:37:39"))
    for column, key in zip(table.columns[1:], ("actor", "action", "target", "result"), strict=True):
        # a name is kept whole (up to NAME_KEPT): a narrow console folds the longest first,
        # where "cli:roo" / "t" and "ivester" / "-demo-p" / "art" could not be read or grepped
        words = [len(word) for entry in entries for word in str(entry[key]).split()]
        column.min_width = min(max(words, default=0), NAME_KEPT)
        free_text(column)  # a name's digit (plan-7, /api/v1/...) makes no number: kept so
    for entry in entries:
        table.add_row(
            entry["at"].strftime("%Y-%m-%d %H:%M:%S"),
            *(Text(entry[key]) for key in ("actor", "action", "target", "result")),
        )
    return table


def said(result: str) -> str:
    """A result that is an HTTP status, with the status's words: ``201 created``.

    A write at the CLI goes through the REST service's code and is audited with its status
    (``201``, ``replayed 201``), which an engineer should not have to look up; the JSON
    keeps the stored value.
    """
    code = result.removeprefix("replayed ")  # the two forms of api/services/transactions.py
    if not (code.isdigit() and len(code) == 3):
        return result
    try:
        return f"{result} {HTTPStatus(int(code)).phrase.lower()}"
    except ValueError:  # not a status Python knows: as stored
        return result


def _detail(detail: Any) -> str:
    """``key: value, ...`` (a table wraps it between pairs); a value not text as JSON."""
    if detail is None:
        return ""
    if not isinstance(detail, dict):
        return json.dumps(detail, ensure_ascii=False)
    return ", ".join(
        f"{key}: {value if isinstance(value, str) else json.dumps(value, ensure_ascii=False)}"
        for key, value in detail.items()
        if value not in ("", None)  # a refusal with no field: "field: ," said nothing
    )
