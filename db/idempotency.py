"""Idempotency records: a completed request's answer by its key, and the in-flight lock."""

from __future__ import annotations

from typing import Any

from sqlalchemy import text
from sqlalchemy.orm import Session

from db import tables as t

#: Core table of the idempotency records (inserted without the ORM's unit of work).
IDEMPOTENCY = t.core_table(t.IdempotencyRecord)

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
