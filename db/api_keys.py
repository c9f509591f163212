"""API keys: who may write and what they may see.

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

from sqlalchemy import JSON, delete, select, text, update
from sqlalchemy.orm import Session

from db import tables as t
from db.idempotency import KEY_LOCK

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


def revoke_key(*, session: Session, key_id: int) -> tuple[t.ApiKey | None, bool]:
    """Mark a key revoked (kept for the audit log): the key (None: none) and whether now.

    A key revoked before keeps its first ``revoked_at``. An id outside the column's range is
    no such key, not an overflow.
    """
    if not 1 <= key_id <= t.MAX_INT:
        return None, False
    row = session.get(t.ApiKey, key_id, with_for_update=True)
    if row is None or row.revoked_at is not None:
        return row, False
    row.revoked_at = t.utcnow()
    # its web view sessions end with it (they find no actor anyway: db.ui_sessions)
    session.execute(delete(t.UiSession).where(t.UiSession.api_key_id == key_id))
    return row, True


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
    return key_actor(row.id, row.role, row.plans), bool(row[5]) if claim else None


def key_actor(key_id: int, role: str, plans: list[int] | None) -> Actor:
    """The actor of a key's row: its id, role and the plans it is scoped to (None: every)."""
    scope = None if plans is None else frozenset(int(p) for p in plans)
    return Actor(key_id, role, f"key:{key_id}", scope)


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
