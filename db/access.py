"""API keys, idempotency records and the audit log: who may write, and what was written.

Keys are 256-bit random tokens, so a plain SHA-256 is the right hash (a slow password hash
buys nothing against a key with that much entropy; OWASP "Password Storage", "pepper" note):
the key is looked up by its hash and the stored hash is compared with
:func:`hmac.compare_digest`, in constant time.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy import JSON, delete, insert, select, text, update
from sqlalchemy.orm import Session

from db import tables as t

#: Roles and what they may do (checked by the REST layer).
ROLES = ("mes", "engineer", "viewer")
#: Prefix of every key, so a leaked key is recognisable in logs and secret scanners.
KEY_PREFIX = "rcb_"


@dataclass(frozen=True)
class Actor:
    """Who is asking: an API key's id and role (``id`` None for the local CLI).

    ``plans``: the plan ids a scoped key may see; None: every plan (an unscoped key, the CLI).
    """

    id: int | None
    role: str
    name: str
    plans: frozenset[int] | None = None

    def may_see(self, plan_id: int) -> bool:
        """Whether the plan is in the actor's reach (a scoped key sees only its plans)."""
        return self.plans is None or plan_id in self.plans


#: Core tables of the append-only rows written here (inserted without the ORM's unit of work).
AUDIT = t.core_table(t.AuditEntry)
IDEMPOTENCY = t.core_table(t.IdempotencyRecord)

#: The engineer at the local command line (not a REST client).
CLI_ACTOR = Actor(None, "engineer", "cli")


def hash_key(key: str) -> str:
    """Hex SHA-256 of a key."""
    return hashlib.sha256(key.encode("utf-8")).hexdigest()


def create_key(
    *, session: Session, role: str, label: str = "", plans: list[int] | None = None
) -> tuple[int, str]:
    """Store a new key of ``role``; returns its id and the key, which is not stored.

    ``plans``: the plan ids the key is scoped to (None: every plan).
    """
    key = KEY_PREFIX + secrets.token_urlsafe(32)
    scope = sorted(set(plans)) if plans is not None else None
    row = t.ApiKey(key_hash=hash_key(key), role=role, label=label, plans=scope)
    session.add(row)
    session.flush()
    return row.id, key


def revoke_key(*, session: Session, key_id: int) -> t.ApiKey | None:
    """Mark a key revoked (kept for the audit log); None if there is no such key."""
    row = session.get(t.ApiKey, key_id)
    if row is not None and row.revoked_at is None:
        row.revoked_at = t.utcnow()
    return row


def authenticate(*, session: Session, key: str) -> Actor | None:
    """The actor holding ``key``, or None for an unknown or revoked key."""
    return authenticate_claiming(session=session, key=key, idempotency_key=None)[0]


def authenticate_claiming(
    *, session: Session, key: str, idempotency_key: str | None
) -> tuple[Actor | None, bool | None]:
    """The actor holding ``key`` and, on PostgreSQL, the in-flight lock of its idempotency key.

    One statement: the key's row and, if it is valid and ``idempotency_key`` is given,
    ``pg_try_advisory_xact_lock`` on that key (:func:`claim_key`), in the session's
    transaction. Returns (actor or None, whether the lock was taken; None if not asked, on
    SQLite, or for an invalid API key).
    """
    digest = hash_key(key)
    claim = idempotency_key is not None and session.get_bind().dialect.name == "postgresql"
    columns = "id, key_hash, role, revoked_at, plans"
    if claim:
        lock = KEY_LOCK.format(api_key_id="id")
        columns += f", CASE WHEN revoked_at IS NULL THEN pg_try_advisory_xact_lock({lock}) END"
    query = text(f"SELECT {columns} FROM api_keys WHERE key_hash = :digest").columns(plans=JSON)
    params = {"digest": digest, "idempotency_key": idempotency_key}
    row = session.execute(query, params).one_or_none()
    if row is None or not hmac.compare_digest(row.key_hash, digest) or row.revoked_at:
        return None, None
    scope = None if row.plans is None else frozenset(int(p) for p in row.plans)
    actor = Actor(row.id, row.role, f"key:{row.id}", scope)
    return actor, bool(row[5]) if claim else None


def touch_key(*, session: Session, key_id: int, at: datetime) -> None:
    """Record the key's last use (``api_keys.last_used_at``)."""
    session.execute(update(t.ApiKey).where(t.ApiKey.id == key_id).values(last_used_at=at))


def list_keys(*, session: Session, after: int, limit: int) -> list[t.ApiKey]:
    """Up to ``limit`` keys with an id above ``after``, by id (revoked ones too)."""
    query = select(t.ApiKey).where(t.ApiKey.id > after).order_by(t.ApiKey.id).limit(limit)
    return list(session.scalars(query))


def plans_missing(*, session: Session, plan_ids: list[int]) -> list[int]:
    """The ids of ``plan_ids`` that name no stored plan."""
    found = set(session.scalars(select(t.Plan.id).where(t.Plan.id.in_(plan_ids))))
    return [p for p in plan_ids if p not in found]


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
) -> None:
    """Append one entry to the audit log (an insert now, in the session's transaction)."""
    session.execute(insert(AUDIT), audit_row(actor, action, target, result, detail))


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
    actor: str, action: str, target: str, result: str, detail: dict[str, Any] | None = None
) -> dict[str, Any]:
    """The row of an audit entry, every column given (for :func:`db.bulk.write_rows`)."""
    return {
        "at": t.utcnow(),
        "actor": actor,
        "action": action,
        "target": target,
        "result": result,
        "detail": detail,
    }


#: The advisory lock of an idempotency key on PostgreSQL: 64 bits of a hash of the key
#: (``:idempotency_key``), seeded with the API key's id (0 for the local CLI).
KEY_LOCK = "hashtextextended(:idempotency_key, {api_key_id})"


def claim_key(*, session: Session, api_key_id: int | None, key: str) -> bool:
    """Take the in-flight lock of an idempotency key for this transaction (PostgreSQL).

    ``pg_try_advisory_xact_lock`` is held until commit or rollback and released by the server
    when the connection dies, so a crashed request never leaves a key stuck in flight.
    On SQLite, writers are serialised by ``BEGIN IMMEDIATE`` and the in-flight check is the
    file lock of :mod:`db.keylock`, taken before the transaction; here it is always True.
    """
    if session.get_bind().dialect.name != "postgresql":
        return True
    query = text(f"SELECT pg_try_advisory_xact_lock({KEY_LOCK.format(api_key_id=':api_key_id')})")
    return bool(session.scalar(query, {"idempotency_key": key, "api_key_id": api_key_id or 0}))


def idempotency_row(
    api_key_id: int | None, key: str, request_hash: str, status: int, body: Any
) -> dict[str, Any]:
    """The row of a completed request's key, every column given (see :func:`audit_row`).

    ``body``: the response body, or it with its JSON text (:class:`db.bulk.Encoded`).
    """
    return {
        "api_key_id": api_key_id,
        "key": key,
        "request_hash": request_hash,
        "state": "done",
        "response_status": status,
        "response_body": body,
        "created_at": t.utcnow(),
    }
