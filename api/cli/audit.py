"""``rcb audit``: who did what to the database, and when, newest first.

Every write over REST or at the CLI, every refused key, every fleet verdict and halt (actor
``rcb``) and every pruning is in the audit log (``audit_log``). This is its reader: a page at
a time, optionally of one action, one actor, one plan, from a time on
(api/services/audit_log.py).
"""

from __future__ import annotations

import json
import shlex
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console
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
        _out.print(_table(page["entries"]))
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


def _table(entries: list[dict[str, Any]]) -> Any:
    """The entries as a table (text as stored, never markup)."""
    table = new_table("at (UTC)", "actor", "action", "target", "result", "detail", title="audit")
    for column, key in zip(
        table.columns[1:5], ("actor", "action", "target", "result"), strict=True
    ):
        # a name is kept whole (up to NAME_KEPT): a narrow console folds the detail first,
        # where "cli:roo" / "t" and "ivester" / "-demo-p" / "art" could not be read or grepped
        words = [len(word) for entry in entries for word in str(entry[key]).split()]
        column.min_width = min(max(words, default=0), NAME_KEPT)
        free_text(column)  # a name's digit (plan-7, /api/v1/...) makes no number: kept so
    # the detail keeps its numbers whole (1796389920.0,), and its keys (window_start_s:) but
    # where the names are folded to their headings' width
    keys = [len(key) + 1 for e in entries if isinstance(e["detail"], dict) for key in e["detail"]]
    free_text(table.columns[5], kept=max(keys, default=0))
    for entry in entries:
        detail = entry["detail"]
        table.add_row(
            entry["at"].strftime("%Y-%m-%d %H:%M:%S"),
            Text(entry["actor"]),
            Text(entry["action"]),
            Text(entry["target"]),
            Text(entry["result"]),
            Text(_detail(detail)),
        )
    return table


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
