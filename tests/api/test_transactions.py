"""A write's transaction helper: what ``after_commit`` runs, and when, on SQLite and PostgreSQL.

A callback registered in the unit of work runs once its answer is committed, and never after a
rollback, a replay, or an attempt that lost a unique-key race and was retried.
"""

from __future__ import annotations

import pytest
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from api.services.idempotency import Written
from api.services.transactions import retried, transaction
from db import tables as t
from db.api_keys import CLI_ACTOR
from db.errors import ConflictError


def _machines(engine, name):
    with Session(engine) as session:
        query = select(func.count()).where(t.Machine.name == name)
        return session.scalar(query.select_from(t.Machine))


def _add_machine(session, name):
    session.add(t.Machine(name=name, limits={}))
    session.flush()


def test_a_callback_runs_after_the_commit_and_sees_the_rows(engine):
    seen = []
    with transaction(engine, CLI_ACTOR, "test", "m1", None) as tx:
        _add_machine(tx.session, "m1")
        tx.after_commit(lambda: seen.append(_machines(engine, "m1")))
        written = tx.answer(201, {"name": "m1"})
        assert seen == []  # not before the commit
    assert seen == [1]  # once, with the row committed (read by another session)
    assert written == Written(201, {"name": "m1"}, text='{"name": "m1"}')


def test_no_callback_after_a_rollback(engine):
    seen = []
    with pytest.raises(RuntimeError, match="refused"):
        with transaction(engine, CLI_ACTOR, "test", "m2", None) as tx:
            _add_machine(tx.session, "m2")
            tx.after_commit(lambda: seen.append("m2"))
            raise RuntimeError("refused")
    assert seen == []
    assert _machines(engine, "m2") == 0


def test_no_callback_after_a_replay(engine):
    seen = []
    stored = Written(201, {"name": "m3"}, True)
    with transaction(engine, CLI_ACTOR, "test", "m3", None) as tx:
        tx.after_commit(lambda: seen.append("m3"))
        assert tx.replayed(stored) is stored
    assert seen == []


def test_no_callback_from_an_attempt_that_lost_a_race_and_was_retried(engine):
    with transaction(engine, CLI_ACTOR, "test", "taken", None) as tx:
        _add_machine(tx.session, "taken")  # what a concurrent request stored first
        tx.answer(201, {})
    seen = []

    def attempt(held):
        number = len(tries) + 1
        tries.append(number)
        with transaction(engine, CLI_ACTOR, "test", "race", None, held) as tx:
            tx.after_commit(lambda: seen.append(number))
            _add_machine(tx.session, "taken" if number == 1 else "free")  # the first one loses
            return tx.answer(201, {"attempt": number})

    tries: list[int] = []
    written = retried(attempt, attempts=3)
    assert tries == [1, 2] and seen == [2]
    assert written.body == {"attempt": 2}
    assert _machines(engine, "free") == 1


def test_a_lost_race_on_the_last_attempt_is_a_conflict_and_runs_nothing(engine):
    with transaction(engine, CLI_ACTOR, "test", "taken", None) as tx:
        _add_machine(tx.session, "taken")
        tx.answer(201, {})
    seen = []

    def attempt(held):
        with transaction(engine, CLI_ACTOR, "test", "race", None, held) as tx:
            tx.after_commit(lambda: seen.append(1))
            _add_machine(tx.session, "taken")
            return tx.answer(201, {})

    with pytest.raises(ConflictError, match="a concurrent request stored the same thing"):
        retried(attempt, attempts=2)
    assert seen == []
