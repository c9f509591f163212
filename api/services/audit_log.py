"""Reading the audit log (CLI only, as ``rcb keys``): ``rcb audit``.

Newest first, a page at a time, optionally of one action, one actor and from a time on.
The log names API keys and the client addresses whose keys were refused, so it is read by
whoever holds the database, not over REST. Errors name the command's options.
"""

from __future__ import annotations

import re
from datetime import datetime
from typing import Any

from sqlalchemy import Engine

from api.services.read.common import _read, _token, _untoken
from api.services.request_limits import READ_PAGE
from api.services.since import since_of
from db import tables as t
from db.audit_read import AuditQuery, entries
from db.table_base import as_utc
from models.errors import InputError

#: Entries on a page unless asked otherwise.
AUDIT_PAGE = 50
#: Longest ``--action`` (the column's width) and ``--actor`` (its column's).
MAX_ACTION, MAX_ACTOR = 100, 200


def query_of(
    action: str | None, actor: str | None, since: str | None, plan_id: int | None = None
) -> AuditQuery:
    """The filters of ``rcb audit``, each checked (InputError naming its option).

    ``plan_id``: the plan ``--plan`` named, resolved (its id or its name).
    """
    for option, value, most in (("--action", action, MAX_ACTION), ("--actor", actor, MAX_ACTOR)):
        if value is None:
            continue
        if not 1 <= len(value) <= most or "\x00" in value:
            raise InputError(option, value, f"1 to {most} characters, no NUL")
    if plan_id is not None and not 1 <= plan_id <= t.MAX_INT:
        raise InputError("--plan", plan_id, f"a plan's id is 1 to {t.MAX_INT}")
    return AuditQuery(action=action, actor=actor, since=since_of(since), plan_id=plan_id)


def _below(cursor: str | None) -> tuple[datetime, int] | None:
    """The time and id a ``--cursor`` of :func:`audit_page` continues below."""
    if cursor is None:
        return None
    refused = InputError("--cursor", cursor, "not a cursor printed by rcb audit")
    try:
        at, entry_id = _untoken(cursor, 2)
        moment = datetime.fromisoformat(at)
    except (InputError, ValueError):
        raise refused from None
    if moment.tzinfo is None or re.fullmatch(r"[0-9]{1,10}", entry_id) is None:
        raise refused
    try:
        moment = as_utc(moment)
    except OverflowError:  # a time in the year 10000 in UTC: no cursor rcb printed
        raise refused from None
    if int(entry_id) > t.MAX_INT:
        raise refused
    return moment, int(entry_id)


def audit_page(
    *, engine: Engine, query: AuditQuery, cursor: str | None = None, limit: int = AUDIT_PAGE
) -> dict[str, Any]:
    """A page of the audit log, newest first: ``{"entries", "next_cursor"}``.

    ``next_cursor``: what ``--cursor`` takes for the older entries, None on the last page.
    """
    if not 1 <= limit <= READ_PAGE:
        raise InputError("--limit", limit, f"must be between 1 and {READ_PAGE}")
    below = _below(cursor)
    with _read(engine) as session, session.begin():
        rows = entries(session=session, query=query, below=below, limit=limit + 1)
    page = rows[:limit]
    last = page[-1] if len(rows) > limit else None
    next_cursor = None if last is None else _token([last["at"].isoformat(), str(last["id"])])
    return {"entries": page, "next_cursor": next_cursor}
