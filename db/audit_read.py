"""Reading the audit log newest first, a page at a time: ``rcb audit``.

A page is ordered by time, then id, both descending, and continues below the last entry of
the previous page (keyset paging: the same rows read on the first page as after a year).
Its filters are served by an index each: one action (``action, at``) and one actor (``actor,
at``, alembic 0024), one plan (``plan_id, at``, alembic 0026), from a time on (``at``).
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy import or_, select
from sqlalchemy.orm import Session

from db.audit import AUDIT
from db.table_base import as_utc


@dataclass(frozen=True)
class AuditQuery:
    """Which entries: ``action``, ``actor``, ``plan_id`` exactly (None: any), ``since`` on.

    ``since``: at or after that time.
    """

    action: str | None = None
    actor: str | None = None
    since: datetime | None = None
    plan_id: int | None = None


def entries(
    *,
    session: Session,
    query: AuditQuery,
    below: tuple[datetime, int] | None,
    limit: int,
) -> list[dict[str, Any]]:
    """Up to ``limit`` entries, newest first, older than ``below`` (its time and id).

    Each: ``id, at`` (UTC), ``actor, action, target, result, detail, plan_id``.
    """
    table = AUDIT
    statement = select(table).order_by(table.c.at.desc(), table.c.id.desc()).limit(limit)
    if query.action is not None:
        statement = statement.where(table.c.action == query.action)
    if query.actor is not None:
        statement = statement.where(table.c.actor == query.actor)
    if query.plan_id is not None:
        statement = statement.where(table.c.plan_id == query.plan_id)
    if query.since is not None:
        statement = statement.where(table.c.at >= as_utc(query.since))
    if below is not None:
        at, entry_id = as_utc(below[0]), below[1]
        # at <= at' bounds the index's range (a deep page seeks, as the first page does)
        statement = statement.where(table.c.at <= at, or_(table.c.at < at, table.c.id < entry_id))
    return [{**row._asdict(), "at": as_utc(row.at)} for row in session.execute(statement).all()]
