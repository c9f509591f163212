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
from typing import Any

from sqlalchemy import insert, select, text
from sqlalchemy.orm import Session

from db import tables as t

#: Roles and what they may do (checked by the REST layer).
ROLES = ("mes", "engineer", "viewer")
#: Prefix of every key, so a leaked key is recognisable in logs and secret scanners.
KEY_PREFIX = "rcb_"


@dataclass(frozen=True)
class Actor:
    """Who is asking: an API key's id and role (``id`` None for the local CLI)."""

    id: int | None
    role: str
    name: str


#: Core tables of the append-only rows written here (inserted without the ORM's unit of work).
AUDIT = t.core_table(t.AuditEntry)
IDEMPOTENCY = t.core_table(t.IdempotencyRecord)

#: The engineer at the local command line (not a REST client).
CLI_ACTOR = Actor(None, "engineer", "cli")


def hash_key(key: str) -> str:
    """Hex SHA-256 of a key."""
    return hashlib.sha256(key.encode("utf-8")).hexdigest()


def create_key(*, session: Session, role: str, label: str = "") -> tuple[int, str]:
    """Store a new key of ``role``; returns its id and the key, which is not stored."""
    key = KEY_PREFIX + secrets.token_urlsafe(32)
    row = t.ApiKey(key_hash=hash_key(key), role=role, label=label)
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
    digest = hash_key(key)
    k = t.ApiKey
    query = select(k.id, k.key_hash, k.role, k.revoked_at).where(k.key_hash == digest)
    row = session.execute(query).one_or_none()
    if row is None or not hmac.compare_digest(row.key_hash, digest) or row.revoked_at:
        return None
    return Actor(row.id, row.role, f"key:{row.id}")


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


def audit_row(
    actor: str, action: str, target: str, result: str, detail: dict[str, Any] | None = None
) -> dict[str, Any]:
    """The row of an audit entry, every column given (for :func:`db.bulk.insert_rows`)."""
    return {
        "at": t.utcnow(),
        "actor": actor,
        "action": action,
        "target": target,
        "result": result,
        "detail": detail,
    }


def claim_key(*, session: Session, scope: str) -> bool:
    """Take the in-flight lock of an idempotency key for this transaction (PostgreSQL).

    ``pg_try_advisory_xact_lock`` is held until commit or rollback and released by the server
    when the connection dies, so a crashed request never leaves a key stuck in flight.
    On SQLite, writers are serialised by ``BEGIN IMMEDIATE`` and the in-flight check is the
    file lock of :mod:`db.keylock`, taken before the transaction; here it is always True.
    """
    if session.get_bind().dialect.name != "postgresql":
        return True
    lock_id = int.from_bytes(hashlib.sha256(scope.encode()).digest()[:8], "big", signed=True)
    return bool(session.scalar(text("SELECT pg_try_advisory_xact_lock(:id)"), {"id": lock_id}))


def find_idempotency(
    *, session: Session, api_key_id: int | None, key: str
) -> t.IdempotencyRecord | None:
    """The completed request stored under ``key`` for this API key, if any."""
    return session.scalars(
        select(t.IdempotencyRecord).where(
            t.IdempotencyRecord.api_key_id == api_key_id, t.IdempotencyRecord.key == key
        )
    ).one_or_none()


def idempotency_row(
    api_key_id: int | None, key: str, request_hash: str, status: int, body: dict[str, Any]
) -> dict[str, Any]:
    """The row of a completed request's key, every column given (see :func:`audit_row`)."""
    return {
        "api_key_id": api_key_id,
        "key": key,
        "request_hash": request_hash,
        "state": "done",
        "response_status": status,
        "response_body": body,
        "created_at": t.utcnow(),
    }
