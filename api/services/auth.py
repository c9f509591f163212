"""Who is asking: API keys checked for the REST routes and the web view, refusals audited.

:func:`authenticate` reads a key for a read (no transaction held). :func:`authenticate_write`
checks the key of a write in the transaction the write goes on in: on PostgreSQL the key's
lookup opens that transaction on one pooled connection and, given the request's
Idempotency-Key, takes that key's in-flight lock in the same statement
(:func:`db.api_keys.authenticate_claiming`); :func:`api.services.parts.report_part` continues it.
Every failure (unknown or revoked key, a role that may not) is appended to the audit log,
on the request's own connection when it holds one (:func:`aside`), coalesced per client
address, action and window over every instance (:mod:`db.audit_windows`), and a failure with
a wrong key from a client address that keeps failing is refused with
:class:`api.services.throttle.RateLimitedError` (429 over REST) instead of 401
(:mod:`api.services.throttle`); a valid key from that address still passes.
A key's last use is recorded at most once a minute per process (for a read, in a thread of its
own, so the read never waits for the write lock).
"""

from __future__ import annotations

import logging
import threading
import time
import weakref
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import partial

from sqlalchemy import Engine
from sqlalchemy.exc import OperationalError, SQLAlchemyError
from sqlalchemy.orm import Session

from api.services import throttle
from api.services.throttle import FailureLimiter, FailureLog, RateLimitedError
from api.settings import auth_failure_burst
from db import api_keys, audit, audit_windows, auth_buckets
from db import tables as t
from db.api_keys import Actor
from db.engine import one_statement_reader, waiting_at_most

__all__ = ["RateLimitedError"]

_log = logging.getLogger(__name__)
#: This process's failure buckets (api.services.throttle), per client address.
LIMITER = FailureLimiter(burst=auth_failure_burst())
#: This process's coalesced failure rows, per engine (the rows' ids are its database's).
_failures: weakref.WeakKeyDictionary[Engine, FailureLog] = weakref.WeakKeyDictionary()
#: A key's ``last_used_at`` is written at most this often per process [s].
TOUCH_S = 60.0
#: Longest a key's last use waits for the write lock [ms]; then it waits for the next use.
TOUCH_WAIT_MS = 250
_touched: dict[int, float] = {}
_touched_lock = threading.Lock()


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


def authenticate(
    *, engine: Engine, key: str | None, action: str, client: str = "", writing: bool = False
) -> Actor | None:
    """The actor of a Bearer key, or None (the failure is audited).

    ``client``: the request's client address, whose failures with a wrong key are counted;
    raises :class:`RateLimitedError` when it has failed too often. The key's last use is
    written in a thread of its own for a read (it never waits for the write lock), before
    returning for a write (``writing``: one connection at a time, as the write's own).
    """
    actor = None
    if key:
        with Session(one_statement_reader(engine)) as session:  # no write lock for a read
            actor = api_keys.authenticate(session=session, key=key)
    if actor is None:
        _audit_unauthenticated(engine, key, action, client)
    elif writing:
        if _due(actor):
            _touch(engine, int(actor.id or 0))
    else:
        used(engine, actor)
    return actor


def used(engine: Engine, actor: Actor) -> None:
    """Record that ``actor``'s key was used for a read.

    At most once a minute per process, in a thread of its own: the read never waits for the
    write lock.
    """
    if _due(actor):
        touch = threading.Thread(target=_touch, args=(engine, int(actor.id or 0)), daemon=True)
        touch.start()


def _touch(engine: Engine, key_id: int) -> None:
    """Record a key's last use in its own short transaction (best effort: logged on failure).

    It waits at most :data:`TOUCH_WAIT_MS` for the write lock: on a SQLite database another
    process holds locked, a part report waited the whole busy timeout here and then again
    for its own write (a lockout review: 60 s to a 503).
    """
    try:
        with (
            waiting_at_most(engine, TOUCH_WAIT_MS) as connection,
            Session(bind=connection) as session,
            session.begin(),
        ):
            api_keys.touch_key(session=session, key_id=key_id, at=t.utcnow())
    except OperationalError as err:  # a busy database: the last use waits for the next
        with _touched_lock:  # the next use writes it, not one a minute later
            _touched.pop(key_id, None)
        if "locked" in str(err).lower() or "busy" in str(err).lower():
            # expected in a burst of reports on SQLite: not a warning in the service's log
            _log.debug("last use of key %s not recorded now: the write lock is busy", key_id)
        else:
            _log.warning("last use of key %s not recorded: %s", key_id, err)


def authenticate_write(
    *,
    engine: Engine,
    key: str | None,
    action: str,
    idempotency_key: str | None = None,
    client: str = "",
) -> Authenticated | None:
    """The authentication of a write request (None: unknown or revoked key, audited).

    On PostgreSQL the key is looked up in a new transaction, and with ``idempotency_key`` its
    in-flight lock is taken by the same statement; the write goes on in that transaction
    (:class:`Authenticated`); the caller closes it when the request ends
    (:meth:`Authenticated.close`). On SQLite, as :func:`authenticate`.
    """
    if not key or engine.dialect.name != "postgresql":
        actor = authenticate(engine=engine, key=key, action=action, client=client, writing=True)
        return None if actor is None else Authenticated(actor)
    session = Session(engine)
    try:
        actor, claimed = api_keys.authenticate_claiming(
            session=session, key=key, idempotency_key=idempotency_key
        )
        if actor is None:
            try:
                _audit_unauthenticated(engine, key, action, client, session)
            finally:
                session.close()
            return None
        if _due(actor):  # in the write's own transaction: no second connection
            api_keys.touch_key(session=session, key_id=int(actor.id or 0), at=t.utcnow())
    except BaseException:
        session.close()
        raise
    return Authenticated(actor, session, claimed)


@contextmanager
def authenticated(
    *,
    engine: Engine,
    key: str | None,
    action: str,
    idempotency_key: str | None = None,
    client: str = "",
) -> Iterator[Authenticated | None]:
    """:func:`authenticate_write` for the duration of the block, closed at its end."""
    held = authenticate_write(
        engine=engine, key=key, action=action, idempotency_key=idempotency_key, client=client
    )
    try:
        yield held
    finally:
        if held is not None:
            held.close()


def _due(actor: Actor) -> bool:
    """Whether the key's last use is to be written now (at most every TOUCH_S per process)."""
    if actor.id is None:
        return False
    now = time.monotonic()
    with _touched_lock:
        if now - _touched.get(actor.id, -TOUCH_S) < TOUCH_S:
            return False
        if len(_touched) > 100_000:
            _touched.clear()
        _touched[actor.id] = now
        return True


def _audit_unauthenticated(
    engine: Engine,
    key: str | None,
    action: str,
    client: str = "",
    session: Session | None = None,
) -> None:
    """Count the failure in its window's audit row; RateLimitedError if ``client`` failed often."""
    reason = "no key" if not key else "unknown or revoked key"
    client = client[:64]  # as the shared rows hold it (auth_buckets, auth_failure_windows)
    with _touched_lock:
        failures = _failures.setdefault(engine, FailureLog())
    failures.record(client, action[:100], reason, partial(_add_failures, engine, session))
    # only a wrong key can guess, or costs a read; the bucket is every instance's (db)
    wait_s = LIMITER.spend(client, partial(_shared_spend, engine, session)) if key else 0
    if wait_s:
        raise RateLimitedError(client or "this client", wait_s)


def _shared_spend(
    engine: Engine,
    session: Session | None,
    client: str,
    now_s: float,
    period_s: float,
    tolerance_s: float,
) -> float | None:
    """Spend ``client``'s failure in the bucket the database holds for every instance.

    A database error leaves the decision to this process's copy (logged): a failing database
    must not turn wrong keys into 500s, and the copy alone still limits this worker.
    """
    try:
        with aside(engine, session) as held:
            return auth_buckets.spend(
                session=held, client=client, now_s=now_s, period_s=period_s,
                tolerance_s=tolerance_s,
            )  # fmt: skip
    except SQLAlchemyError as err:
        _log.warning("shared wrong-key bucket not read: %s", err)
        return None


def _add_failures(
    engine: Engine,
    session: Session | None,
    client: str,
    action: str,
    reason: str,
    start_s: float,
    window_s: float,
    delta: int,
) -> int:
    """Add failures to their window's count over every instance (``session``: :func:`aside`)."""
    with aside(engine, session) as held:
        return audit_windows.add(
            session=held, client=client, action=action, reason=reason, start_s=start_s,
            window_s=window_s, delta=delta,
        )  # fmt: skip


def flush_failures(engine: Engine) -> int:
    """Write the failure counts of ``engine`` this process holds in memory; rows written.

    Called on a timer and at shutdown (:mod:`api.rest.lifespan`), each row in its own
    transaction on a connection of its own. A database error is logged and the counts stay
    pending for the next call.
    """
    with _touched_lock:
        failures = _failures.get(engine)
    if failures is None:
        return 0
    try:
        _prune(engine)
        return failures.flush(partial(_add_failures, engine, None))
    except SQLAlchemyError as err:
        _log.warning("authentication failure counts not written yet: %s", err)
        return 0


#: Shortest time between two prunes of the shared buckets by one process [s].
PRUNE_S = 60.0
_pruned_at: weakref.WeakKeyDictionary[Engine, float] = weakref.WeakKeyDictionary()


def _prune(engine: Engine) -> None:
    """Delete full shared buckets and ended audit windows, at most every :data:`PRUNE_S`."""
    now = time.monotonic()
    with _touched_lock:
        if now - _pruned_at.get(engine, -PRUNE_S) < PRUNE_S:
            return
        _pruned_at[engine] = now
    with Session(engine) as session, session.begin():
        auth_buckets.prune(session=session, now_s=time.time())
        # a window no process still adds to (theirs ended): its audit entry stays
        audit_windows.prune(session=session, before_s=time.time() - 2 * throttle.WINDOW_S)


def audit_forbidden(
    *, engine: Engine, actor: Actor, action: str, held: Authenticated | None = None
) -> None:
    """Record a request refused for the actor's role (``held``: see :func:`authenticated`)."""
    with aside(engine, held.session if held else None) as session:
        audit.audit(session=session, actor=actor.name, action=action, target="", result="forbidden")
