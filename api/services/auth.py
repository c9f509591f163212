"""Who is asking: API keys checked for the REST routes and the web view, refusals audited.

:func:`authenticate` reads a key for a read (no transaction held). :func:`authenticate_write`
checks the key of a write in the transaction the write goes on in: on PostgreSQL the key's
lookup opens that transaction on one pooled connection and, given the request's
Idempotency-Key, takes that key's in-flight lock in the same statement
(:func:`db.access.authenticate_claiming`); :func:`api.services.parts.report_part` continues it.
Every failure (unknown or revoked key, a role that may not) is appended to the audit log,
on the request's own connection when it holds one (:func:`aside`).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from sqlalchemy import Engine
from sqlalchemy.orm import Session

from db import access
from db.access import Actor
from db.engine import one_statement_reader


@dataclass
class Authenticated:
    """A request's actor and, on PostgreSQL, the transaction its API key was checked in.

    ``session`` is that transaction (one connection); the request's write goes on in it
    (:func:`api.services.transactions.write`), so a part report takes one connection from the
    pool, not two, and its idempotency key's in-flight lock (``claimed``) was taken by the key's
    own lookup. On SQLite the key is read outside a transaction and both are None.
    """

    actor: Actor
    session: Session | None = None
    claimed: bool | None = None

    def close(self) -> None:
        """Give the connection back (an open transaction is rolled back); idempotent."""
        if self.session is not None:
            session, self.session, self.claimed = self.session, None, None
            session.close()


@contextmanager
def aside(engine: Engine, held: Session | None) -> Iterator[Session]:
    """A transaction for an audit entry of a refused request.

    In ``held``, the request's session (its open transaction rolled back first), so a request
    never takes a second connection from the pool; else in a new session.
    """
    if held is None:
        with Session(engine) as session, session.begin():
            yield session
        return
    if held.in_transaction():
        held.rollback()
    with held.begin():
        yield held


def authenticate(*, engine: Engine, key: str | None, action: str) -> Actor | None:
    """The actor of a Bearer key, or None (the failure is audited)."""
    actor = None
    if key:
        with Session(one_statement_reader(engine)) as session:  # no write lock for a read
            actor = access.authenticate(session=session, key=key)
    if actor is None:
        _audit_unauthenticated(engine, key, action)
    return actor


def authenticate_write(
    *, engine: Engine, key: str | None, action: str, idempotency_key: str | None = None
) -> Authenticated | None:
    """The authentication of a write request (None: unknown or revoked key, audited).

    On PostgreSQL the key is looked up in a new transaction, and with ``idempotency_key`` its
    in-flight lock is taken by the same statement; the write goes on in that transaction
    (:class:`Authenticated`); the caller closes it when the request ends
    (:meth:`Authenticated.close`). On SQLite, as :func:`authenticate`.
    """
    if not key or engine.dialect.name != "postgresql":
        actor = authenticate(engine=engine, key=key, action=action)
        return None if actor is None else Authenticated(actor)
    session = Session(engine)
    try:
        actor, claimed = access.authenticate_claiming(
            session=session, key=key, idempotency_key=idempotency_key
        )
        if actor is None:
            _audit_unauthenticated(engine, key, action, session)
            session.close()
            return None
    except BaseException:
        session.close()
        raise
    return Authenticated(actor, session, claimed)


@contextmanager
def authenticated(
    *, engine: Engine, key: str | None, action: str, idempotency_key: str | None = None
) -> Iterator[Authenticated | None]:
    """:func:`authenticate_write` for the duration of the block, closed at its end."""
    held = authenticate_write(
        engine=engine, key=key, action=action, idempotency_key=idempotency_key
    )
    try:
        yield held
    finally:
        if held is not None:
            held.close()


def _audit_unauthenticated(
    engine: Engine, key: str | None, action: str, session: Session | None = None
) -> None:
    with aside(engine, session) as session:
        access.audit(
            session=session,
            actor="anonymous",
            action=action,
            target="",
            result="unauthenticated",
            detail={"reason": "no key" if not key else "unknown or revoked key"},
        )


def audit_forbidden(
    *, engine: Engine, actor: Actor, action: str, held: Authenticated | None = None
) -> None:
    """Record a request refused for the actor's role (``held``: see :func:`authenticated`)."""
    with aside(engine, held.session if held else None) as session:
        access.audit(
            session=session, actor=actor.name, action=action, target="", result="forbidden"
        )
