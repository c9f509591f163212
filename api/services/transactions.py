"""The transaction every write runs in: idempotent, retried on unique-key races, audited.

:func:`write` runs a use case's work in one transaction and stores, with its rows, the
Idempotency-Key's record (:mod:`api.services.idempotency`) and the audit entry; :func:`audited`
appends a refused write to the audit log.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from sqlalchemy import Engine
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from api.services.auth import Authenticated, aside
from api.services.idempotency import Idempotency, InFlightError, Written, replay_of
from db import audit, bulk, keylock
from db.api_keys import Actor
from db.errors import ConflictError
from db.idempotency import IDEMPOTENCY, claim_key, idempotency_row
from db.intake import stored_answer

#: A write's work in its transaction: (status, body), or a replay found by the work itself.
Work = Callable[[Session], "tuple[int, dict[str, Any]] | Written"]


def write(
    engine: Engine,
    *,
    actor: Actor,
    action: str,
    target: str,
    idempotency: Idempotency | None,
    work: Work,
    attempts: int = 1,
    held: Authenticated | None = None,
    finds_replay: bool = False,
) -> Written:
    """Run ``work`` in one transaction, idempotently; ``attempts`` > 1 retries unique-key races.

    Creating a plan inserts its machine and tools if they are new: two plans for the same new
    machine at once race to insert it, and the loser's retry finds it stored. ``held``: the
    request's authentication, whose open transaction (if any) the first attempt goes on in.
    ``finds_replay``: ``work`` looks the key's stored answer up itself (after the key's lock,
    in its first statement) and returns it as a :class:`Written`.
    """
    for attempt in range(1, attempts + 1):
        try:
            return _write_once(
                engine,
                actor=actor,
                action=action,
                target=target,
                idempotency=idempotency,
                work=work,
                held=held if attempt == 1 else None,
                finds_replay=finds_replay,
            )
        except ConflictError as err:
            if attempt == attempts or not isinstance(err.__cause__, IntegrityError):
                raise
    raise AssertionError("unreachable")


def _write_once(
    engine: Engine,
    *,
    actor: Actor,
    action: str,
    target: str,
    idempotency: Idempotency | None,
    work: Work,
    held: Authenticated | None,
    finds_replay: bool,
) -> Written:
    scope = f"{actor.id}:{idempotency.key}" if idempotency else ""
    guard = keylock.in_flight(engine, scope) if idempotency else _free()
    try:
        with guard as free:
            if not free:
                raise InFlightError(idempotency.key if idempotency else "")
            with _transaction(engine, held) as (session, claimed):
                stored = None
                if idempotency is not None:
                    if claimed is None:
                        claimed = claim_key(
                            session=session, api_key_id=actor.id, key=idempotency.key
                        )
                    if not claimed:
                        raise InFlightError(idempotency.key)
                    if not finds_replay:
                        stored = replay_of(
                            stored_answer(session, actor.id, idempotency.key), idempotency
                        )
                done = stored or work(session)
                if isinstance(done, Written):
                    audit.audit(
                        session=session,
                        actor=actor.name,
                        action=action,
                        target=target,
                        result=f"replayed {done.status}",
                    )
                    return done
                status, body = done
                answer = bulk.Encoded.of(body)
                # the key's record and the audit entry go out with the rows the work deferred
                # (a part report's: one statement on PostgreSQL, db.bulk)
                rows = [(audit.AUDIT, [audit.audit_row(actor.name, action, target, str(status))])]
                if idempotency is not None:
                    record = idempotency_row(
                        actor.id, idempotency.key, idempotency.request_hash, status, answer
                    )
                    rows.insert(0, (IDEMPOTENCY, [record]))
                bulk.write_deferred(session, rows)
                return Written(status, body, text=answer.text)
    except IntegrityError as err:
        # a concurrent write won a unique constraint (same serial, same key): nothing was stored
        raise ConflictError(
            "request", target, "a concurrent request stored the same thing"
        ) from err


@contextmanager
def _transaction(
    engine: Engine, held: Authenticated | None
) -> Iterator[tuple[Session, bool | None]]:
    """A session in a transaction, committed if the block ends without an exception.

    With ``held`` that has a session: that session, in the transaction its key was checked in
    (the first time; then whether the key's lock was taken in it) or in a new one; else a new
    session, and None.
    """
    if held is None or held.session is None:
        with Session(engine) as session, session.begin():
            yield session, None
        return
    session, claimed = held.session, held.claimed
    held.claimed = None  # the lock lasts as long as the transaction it was taken in
    if not session.in_transaction():
        session.begin()
    try:
        yield session, claimed
        session.commit()
    except BaseException:
        session.rollback()
        raise


class _free:
    def __enter__(self) -> bool:
        return True

    def __exit__(self, *exc: object) -> None:
        return None


@contextmanager
def audited(
    engine: Engine, actor: Actor, action: str, target: str, held: Authenticated | None = None
) -> Iterator[None]:
    """Append a refused write (any exception) to the audit log, then let it propagate."""
    try:
        yield
    except Exception as err:
        detail = {
            "error": err.__class__.__name__,
            "field": str(getattr(err, "field", "")),
            "message": str(err)[:500],
        }
        with aside(engine, held.session if held else None) as session:
            audit.audit(
                session=session,
                actor=actor.name,
                action=action,
                target=target,
                result="refused",
                detail=detail,
            )
        raise
