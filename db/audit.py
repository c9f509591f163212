"""The audit log: what was written, by whom; and pruning the append-only tables.

Rows are appended with Core inserts (no ORM unit of work): one entry now
(:func:`audit`), or a row for :func:`db.bulk.write_rows` (:func:`audit_row`).
"""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import delete, insert, update
from sqlalchemy.orm import Session

from db import tables as t
from db.idempotency import IDEMPOTENCY
from models.fields import escaped

#: Core table of the audit log (inserted without the ORM's unit of work).
AUDIT = t.core_table(t.AuditEntry)
#: The most characters of an entry's target (a refused plan's name is logged as sent).
MAX_TARGET = 300


def prune(
    *, session: Session, audit_before: datetime, idempotency_before: datetime
) -> dict[str, int]:
    """Delete audit entries and idempotency records older than the given times.

    Returns how many rows of each table were deleted:
    ``{"audit_log": n, "idempotency_records": m}``.
    """
    counted = {
        "audit_log": (AUDIT, AUDIT.c.at < audit_before),
        "idempotency_records": (IDEMPOTENCY, IDEMPOTENCY.c.created_at < idempotency_before),
    }
    deleted = {}
    for name, (table, older) in counted.items():
        result = session.execute(delete(table).where(older))
        deleted[name] = int(getattr(result, "rowcount", 0))
    return deleted


def audit(
    *,
    session: Session,
    actor: str,
    action: str,
    target: str,
    result: str,
    detail: dict[str, Any] | None = None,
    plan_id: int | None = None,
) -> None:
    """Append one entry to the audit log (an insert now, in the session's transaction).

    ``plan_id``: the plan the entry is about, if any (``rcb audit --plan``).
    """
    session.execute(insert(AUDIT), audit_row(actor, action, target, result, detail, plan_id))


def audit_returning_id(*, session: Session, row: dict[str, Any]) -> int:
    """Append the audit entry ``row`` (see :func:`audit_row`); returns its id."""
    return int(session.execute(insert(AUDIT).returning(AUDIT.c.id), row).scalar_one())


def set_audit_detail(*, session: Session, entry_id: int, detail: dict[str, Any]) -> bool:
    """Replace the ``detail`` of an audit entry (a coalesced entry's count grows).

    Returns whether the entry was there (False: it was pruned meanwhile).
    """
    result = session.execute(update(AUDIT).where(AUDIT.c.id == entry_id).values(detail=detail))
    return bool(getattr(result, "rowcount", 0))


def audit_row(
    actor: str,
    action: str,
    target: str,
    result: str,
    detail: dict[str, Any] | None = None,
    plan_id: int | None = None,
) -> dict[str, Any]:
    """The row of an audit entry, every column given (for :func:`db.bulk.write_rows`)."""
    return {
        "at": t.utcnow(),
        "actor": actor,
        "action": action,
        "target": escaped(target, nul=True)[:MAX_TARGET],
        "result": result,
        "detail": escaped(detail, nul=True),  # what was sent, as a column holds it
        "plan_id": plan_id,
    }
