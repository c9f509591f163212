"""Reading the audit log newest first, a page at a time: ``rcb audit``.

A page is ordered by time, then id, both descending, and continues below the last entry of
the previous page (keyset paging: the same rows read on the first page as after a year).
Its filters are served by an index each: one action (``action, at``) and one actor (``actor,
at``, alembic 0024), one plan (``plan_id, at``, alembic 0026), from a time on (``at``). One
plan's history holds its machine's fleet exclusions and inclusions too (``rcb fleet exclude
--machine``: no ``plan_id``, the target ``machine NAME``), read through the action's index:
each of the three reads its index in the page's order and the page merges them.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy import ColumnElement, Select, literal, or_, select, union_all
from sqlalchemy.orm import Session

from db import tables as t
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
    where = _filters(query, below)
    if query.plan_id is None:
        members = [select(AUDIT).where(*where)]
    else:
        members = [select(AUDIT).where(AUDIT.c.plan_id == query.plan_id, *where)]
        machine = (
            select(literal("machine ") + t.Machine.name)
            .join(t.Plan, t.Plan.machine_id == t.Machine.id)
            .where(t.Plan.id == query.plan_id)
            .scalar_subquery()
        )
        for action in MACHINE_ACTIONS:
            if query.action in (None, action):
                about = (AUDIT.c.action == action, AUDIT.c.target == machine)
                members.append(select(AUDIT).where(*about, *where))
    if len(members) > 1:  # each its page, as it reads its index; the page merges them
        pages = [_newest(m, limit).subquery() for m in members]
        members = [union_all(*(select(page) for page in pages)).subquery().select()]
    statement = _newest(members[0], limit)
    return [{**row._asdict(), "at": as_utc(row.at)} for row in session.execute(statement).all()]


def _newest(statement: Select[Any], limit: int) -> Select[Any]:
    """``statement``'s newest ``limit`` rows: by time, then id, both descending."""
    columns = statement.selected_columns
    return statement.order_by(columns.at.desc(), columns.id.desc()).limit(limit)


#: The actions of a machine's entries a plan's history holds (``rcb fleet ... --machine``).
MACHINE_ACTIONS = ("fleet exclude", "fleet include")


def _filters(query: AuditQuery, below: tuple[datetime, int] | None) -> list[ColumnElement[bool]]:
    """The conditions of ``query`` but its plan, and below the cursor's ``below``."""
    table = AUDIT
    where: list[ColumnElement[bool]] = []
    if query.action is not None:
        where.append(table.c.action == query.action)
    if query.actor is not None:
        where.append(table.c.actor == query.actor)
    if query.since is not None:
        where.append(table.c.at >= as_utc(query.since))
    if below is not None:
        at, entry_id = as_utc(below[0]), below[1]
        # at <= at' bounds the index's range (a deep page seeks, as the first page does)
        where += [table.c.at <= at, or_(table.c.at < at, table.c.id < entry_id)]
    return where
