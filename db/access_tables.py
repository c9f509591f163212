"""Tables of who may ask and what was asked: keys, idempotency, audit, shared limits.

API keys, idempotency records, the audit log, and the wrong-key limits and audit windows
every instance on the database shares (issue 33).

Re-exported by :mod:`db.tables` (``t.ApiKey`` ...), where the rest of the schema is.
"""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import JSON, ForeignKey, Index, String, Text, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column

from db.table_base import Base, utcnow


class ApiKey(Base):
    """An API key, stored only as a hash, with its role."""

    __tablename__ = "api_keys"
    id: Mapped[int] = mapped_column(primary_key=True)
    key_hash: Mapped[str] = mapped_column(String(128), unique=True)
    role: Mapped[str] = mapped_column(String(20))
    label: Mapped[str] = mapped_column(Text, default="")
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    revoked_at: Mapped[datetime | None]
    #: the plan ids the key may see (NULL: every plan, as before 0006)
    plans: Mapped[list[int] | None] = mapped_column(JSON(none_as_null=True))
    #: the last request the key authenticated, to the minute (NULL: never used)
    last_used_at: Mapped[datetime | None]


class IdempotencyRecord(Base):
    """A POST's Idempotency-Key: its request hash and, once done, the stored response."""

    __tablename__ = "idempotency_records"
    __table_args__ = (UniqueConstraint("api_key_id", "key"),)
    id: Mapped[int] = mapped_column(primary_key=True)
    api_key_id: Mapped[int | None] = mapped_column(ForeignKey("api_keys.id"))
    key: Mapped[str] = mapped_column(String(255))
    request_hash: Mapped[str] = mapped_column(String(64))
    state: Mapped[str] = mapped_column(String(20))
    response_status: Mapped[int | None]
    response_body: Mapped[dict[str, Any] | None]
    created_at: Mapped[datetime] = mapped_column(default=utcnow, index=True)


class AuthBucket(Base):
    """A client address's wrong-key allowance, shared by every instance (db.auth_buckets).

    ``tat_s``: the time [s, Unix] at which its bucket is full again plus one period (the
    generic cell rate algorithm's theoretical arrival time).
    """

    __tablename__ = "auth_buckets"
    client: Mapped[str] = mapped_column(String(64), primary_key=True)
    tat_s: Mapped[float]


class AuditEntry(Base):
    """Append-only audit log: who did what, when, with what result (``rcb audit`` reads it)."""

    __tablename__ = "audit_log"
    __table_args__ = (  # rcb audit --action / --actor / --plan, newest first (db.audit_read,
        # alembic 0024 and 0026)
        Index("ix_audit_log_action_at", "action", "at"),
        Index("ix_audit_log_actor_at", "actor", "at"),
        Index("ix_audit_log_plan_id_at", "plan_id", "at"),
    )
    id: Mapped[int] = mapped_column(primary_key=True)
    at: Mapped[datetime] = mapped_column(default=utcnow, index=True)
    actor: Mapped[str] = mapped_column(String(200))
    action: Mapped[str] = mapped_column(String(100))
    target: Mapped[str] = mapped_column(Text, default="")
    result: Mapped[str] = mapped_column(String(50))
    detail: Mapped[dict[str, Any] | None]
    #: The plan the entry is about (its creation, a part report, a replan, a fleet verdict);
    #: None for the rest. No foreign key: the log is append-only and outlives what it names.
    plan_id: Mapped[int | None] = mapped_column(default=None)


class AuthFailureWindow(Base):
    """Authentication failures of one client, action and reason in one audit window.

    Counted over every instance (:mod:`db.audit_windows`); ``audit_id``: the audit entry
    whose ``detail.count`` shows the sum (NULL until written). ``window_start_s``: Unix [s].
    """

    __tablename__ = "auth_failure_windows"
    client: Mapped[str] = mapped_column(String(64), primary_key=True)
    action: Mapped[str] = mapped_column(String(100), primary_key=True)
    reason: Mapped[str] = mapped_column(String(50), primary_key=True)
    window_start_s: Mapped[float] = mapped_column(primary_key=True)
    count: Mapped[int]
    audit_id: Mapped[int | None]


class UiSession(Base):
    """A sign-in to the web view (``/ui``): its cookie's token, stored only as a hash.

    The cookie held the API key itself before 0030: a copied cookie was the key, for every
    route of its role, and signing out only deleted the browser's copy. A session is the key's
    for reading the view only, ends at ``expires_at`` or at sign-out, and with its key
    (revoked or deleted) (:mod:`db.ui_sessions`).
    """

    __tablename__ = "ui_sessions"
    id: Mapped[int] = mapped_column(primary_key=True)
    token_hash: Mapped[str] = mapped_column(String(64), unique=True)
    api_key_id: Mapped[int] = mapped_column(ForeignKey("api_keys.id", ondelete="CASCADE"))
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    expires_at: Mapped[datetime] = mapped_column(index=True)
