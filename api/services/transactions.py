"""The transaction every write runs in: idempotent, retried on unique-key races, audited.

:func:`transaction` is a write's transaction (:class:`Tx`): the block stores its rows and ends
with an answer, stored with the Idempotency-Key's record (:mod:`api.services.idempotency`) and
the audit entry, or with the answer stored under the key; what the block leaves for after the
commit (:meth:`Tx.after_commit`) runs once it has committed. :func:`write` runs a use case's work
in one, retried on unique-key races (:func:`retried`); :func:`audited` appends a refused write
to the audit log.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
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

#: A write's work in its transaction: the answer's status and body.
Work = Callable[[Session], "tuple[int, dict[str, Any]]"]
#: The plan a write is about, for its audit entry (``rcb audit --plan``): its id, the key of
#: the answer that holds it (a new plan's ``"id"``), or None.
AuditPlan = int | str | None


class Tx:
    """A write's open transaction, as the unit of work in it sees it.

    ``session``: the transaction's session. The work ends with :meth:`answer` (a new answer:
    the key's record and the audit entry are stored with its rows) or :meth:`replayed` (the
    answer stored under the key, nothing new written). :meth:`after_commit` keeps what to do
    once the rows are committed, such as caching the state they hold: it runs only after the
    commit of an answer, never after a rollback, a replay or an attempt that was retried.
    """

    def __init__(
        self,
        session: Session,
        actor: Actor,
        action: str,
        target: str,
        idempotency: Idempotency | None,
        detail: dict[str, Any] | None = None,
        plan: AuditPlan = None,
    ) -> None:
        self.session = session
        self._actor, self._action, self._target = actor, action, target
        self._detail, self._plan = detail, plan
        self._idempotency = idempotency
        self._after: list[Callable[[], None]] = []
        self._answered = False

    def after_commit(self, callback: Callable[[], None]) -> None:
        """Call ``callback`` once this transaction has committed its answer."""
        self._after.append(callback)

    def answer(self, status: int, body: dict[str, Any]) -> Written:
        """The new answer, stored with the key's record and the audit entry (to be committed)."""
        actor, idempotency = self._actor, self._idempotency
        answer = bulk.Encoded.of(body)
        # the key's record and the audit entry go out with the rows the work deferred
        # (a part report's: one statement on PostgreSQL, db.bulk)
        entry = audit.audit_row(
            actor.name, self._action, self._target, str(status), self._detail, self._plan_in(body)
        )
        rows = [(audit.AUDIT, [entry])]
        if idempotency is not None:
            record = idempotency_row(
                actor.id, idempotency.key, idempotency.request_hash, status, answer
            )
            rows.insert(0, (IDEMPOTENCY, [record]))
        bulk.write_deferred(self.session, rows)
        self._answered = True
        return Written(status, body, text=answer.text)

    def replayed(self, stored: Written) -> Written:
        """The answer stored under the key, audited as replayed; nothing to do after commit."""
        audit.audit(
            session=self.session,
            actor=self._actor.name,
            action=self._action,
            target=self._target,
            result=f"replayed {stored.status}",
            plan_id=self._plan_in(stored.body),
        )
        self._answered = False
        return stored

    def _plan_in(self, body: Any) -> int | None:
        """The plan of the audit entry: given, or the answer's field of that name."""
        if not isinstance(self._plan, str):
            return self._plan
        found = body.get(self._plan) if isinstance(body, dict) else None
        return found if isinstance(found, int) else None

    def _committed(self) -> None:
        """Run the callbacks of a committed answer (once)."""
        callbacks, self._after = (self._after if self._answered else []), []
        for callback in callbacks:
            callback()


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
    detail: dict[str, Any] | None = None,
    plan: AuditPlan = None,
) -> Written:
    """Run ``work`` in one transaction, idempotently; ``attempts`` > 1 retries unique-key races.

    ``detail``: what the audit entry keeps besides its action and target (an exclusion's reason).
    ``plan``: the plan the entry is about (:data:`AuditPlan`).

    Creating a plan inserts its machine and tools if they are new: two plans for the same new
    machine at once race to insert it, and the loser's retry finds it stored. ``held``: the
    request's authentication, whose open transaction (if any) the first attempt goes on in.
    """

    def once(held: Authenticated | None) -> Written:
        with transaction(engine, actor, action, target, idempotency, held, detail, plan) as tx:
            stored = None
            if idempotency is not None:
                found = stored_answer(tx.session, actor.id, idempotency.key)
                stored = replay_of(found, idempotency)
            if stored is not None:
                return tx.replayed(stored)
            return tx.answer(*work(tx.session))

    return retried(once, attempts, held)


def retried(
    attempt: Callable[[Authenticated | None], Written],
    attempts: int,
    held: Authenticated | None = None,
) -> Written:
    """``attempt(held)``, then up to ``attempts`` - 1 retries of it after a unique-key race.

    A race is a :class:`ConflictError` caused by an :class:`IntegrityError` (:func:`transaction`
    raises it); each retry is a new transaction (``held`` only goes to the first).
    """
    for number in range(1, attempts + 1):
        try:
            return attempt(held if number == 1 else None)
        except ConflictError as err:
            if number == attempts or not isinstance(err.__cause__, IntegrityError):
                raise
    raise AssertionError("unreachable")


@contextmanager
def transaction(
    engine: Engine,
    actor: Actor,
    action: str,
    target: str,
    idempotency: Idempotency | None,
    held: Authenticated | None = None,
    detail: dict[str, Any] | None = None,
    plan: AuditPlan = None,
) -> Iterator[Tx]:
    """A write's transaction (:class:`Tx`): committed if the block ends without an exception.

    With an Idempotency-Key, the key must be free (not in flight) and is claimed in the
    transaction; the block looks its stored answer up (:func:`db.intake.stored_answer`, or in
    a statement of its own, as a part report does). ``held``: the request's authentication,
    whose open transaction (if any) the block goes on in. A unique constraint a concurrent
    write won is a :class:`ConflictError`. After the commit, the callbacks of
    :meth:`Tx.after_commit` run if the block answered.
    """
    scope = f"{actor.id}:{idempotency.key}" if idempotency else ""
    guard = keylock.in_flight(engine, scope) if idempotency else _free()
    try:
        with guard as free:
            if not free:
                raise InFlightError(idempotency.key if idempotency else "")
            with _transaction(engine, held) as (session, claimed):
                if idempotency is not None:
                    if claimed is None:
                        claimed = claim_key(
                            session=session, api_key_id=actor.id, key=idempotency.key
                        )
                    if not claimed:
                        raise InFlightError(idempotency.key)
                tx = Tx(session, actor, action, target, idempotency, detail, plan)
                yield tx
    except IntegrityError as err:
        # a concurrent write won a unique constraint (same serial, same key): nothing was stored
        raise ConflictError(
            "request", target, "a concurrent request stored the same thing"
        ) from err
    tx._committed()


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
    engine: Engine,
    actor: Actor,
    action: str,
    target: str,
    held: Authenticated | None = None,
    plan_id: int | None = None,
    kept: Mapping[str, Any] | None = None,
) -> Iterator[None]:
    """Append a refused write (any exception) to the audit log, then let it propagate.

    ``plan_id``: the plan the write was about, if known before it ran. ``kept``: what the
    entry keeps beside the refusal (an engineer's reason that passed its check,
    :func:`db.fleet_exclusions.kept_reason`).
    """
    try:
        yield
    except Exception as err:
        detail = {
            "error": err.__class__.__name__,
            "field": str(getattr(err, "field", "")),
            "message": str(err)[:500],
            **(kept or {}),
        }
        with aside(engine, held.session if held else None) as session:
            audit.audit(
                session=session,
                actor=actor.name,
                action=action,
                target=target,
                result="refused",
                detail=detail,
                plan_id=plan_id,
            )
        raise
