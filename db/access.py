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

from sqlalchemy import insert, text
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
    columns = "id, key_hash, role, revoked_at"
    if claim:
        lock = KEY_LOCK.format(api_key_id="id")
        columns += f", CASE WHEN revoked_at IS NULL THEN pg_try_advisory_xact_lock({lock}) END"
    query = text(f"SELECT {columns} FROM api_keys WHERE key_hash = :digest")
    params = {"digest": digest, "idempotency_key": idempotency_key}
    row = session.execute(query, params).one_or_none()
    if row is None or not hmac.compare_digest(row.key_hash, digest) or row.revoked_at:
        return None, None
    return Actor(row.id, row.role, f"key:{row.id}"), bool(row[4]) if claim else None


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
