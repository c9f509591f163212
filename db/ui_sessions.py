"""Sign-ins to the web view (``/ui``): a random token per sign-in, its key's, until it ends.

The cookie carries the token; the table keeps its SHA-256 (a 256-bit random token needs no
slow hash: :mod:`db.api_keys`). A session is its API key's for reading the view: it ends at
``expires_at``, at sign-out (its row deleted), and with its key: a revoked key's sessions
find no actor, a deleted key's rows go with it (``ON DELETE CASCADE``). The table is
bounded: a sign-in deletes the sessions that have ended, and keeps at most
:data:`MAX_PER_KEY` of its key's newest.
"""

from __future__ import annotations

import hmac
import secrets
from datetime import datetime, timedelta

from sqlalchemy import delete, select
from sqlalchemy.orm import Session

from db import tables as t
from db.api_keys import Actor, hash_key, key_actor

#: Sessions one key may hold at once (browsers, shifts); a new sign-in ends the oldest.
MAX_PER_KEY = 20
#: Prefix of a session's token, so a leaked one is told from an API key (``rcb_``).
TOKEN_PREFIX = "rcbui_"


def open_session(*, session: Session, key_id: int, now: datetime, lasts_s: float) -> str:
    """A new session of key ``key_id`` lasting ``lasts_s``; returns its token (not stored)."""
    session.execute(delete(t.UiSession).where(t.UiSession.expires_at <= now))
    kept = (
        select(t.UiSession.id)
        .where(t.UiSession.api_key_id == key_id)
        .order_by(t.UiSession.id.desc())
        .limit(MAX_PER_KEY - 1)
    )
    session.execute(
        delete(t.UiSession).where(
            t.UiSession.api_key_id == key_id, t.UiSession.id.not_in(kept.scalar_subquery())
        )
    )
    token = TOKEN_PREFIX + secrets.token_urlsafe(32)
    expires = now + timedelta(seconds=lasts_s)
    session.add(t.UiSession(token_hash=hash_key(token), api_key_id=key_id, expires_at=expires))
    session.flush()
    return token


def actor_of(*, session: Session, token: str, now: datetime) -> Actor | None:
    """The actor of a session's token: None if unknown, ended, or its key revoked."""
    digest = hash_key(token)
    query = (
        select(t.UiSession.token_hash, t.ApiKey.id, t.ApiKey.role, t.ApiKey.plans)
        .join(t.ApiKey, t.ApiKey.id == t.UiSession.api_key_id)
        .where(
            t.UiSession.token_hash == digest,
            t.UiSession.expires_at > now,  # bound as the column's type (SQLite's text form)
            t.ApiKey.revoked_at.is_(None),
        )
    )
    row = session.execute(query).one_or_none()
    if row is None or not hmac.compare_digest(row.token_hash, digest):
        return None
    return key_actor(row.id, row.role, row.plans)


def close_session(*, session: Session, token: str) -> bool:
    """End the session of ``token`` (sign-out); whether there was one."""
    done = session.execute(delete(t.UiSession).where(t.UiSession.token_hash == hash_key(token)))
    return bool(getattr(done, "rowcount", 0))
