"""db.bulk's deferred rows are hooked on the project's engines only, and never outlive a
transaction."""

from __future__ import annotations

import pytest
from sqlalchemy import Column, Integer, MetaData, Table, create_engine, event, select
from sqlalchemy.orm import Session

from db import bulk
from db.engine import make_engine


def _table() -> tuple[MetaData, Table]:
    metadata = MetaData()
    return metadata, Table(
        "rows", metadata, Column("id", Integer, primary_key=True), Column("n", Integer)
    )


@pytest.fixture
def engine(tmp_path):
    engine = make_engine(f"sqlite:///{tmp_path / 'hooks.db'}")
    yield engine
    engine.dispose()


def test_no_session_class_is_hooked():
    for name in ("before_commit", "after_rollback"):
        assert not event.contains(Session, name, bulk._write_left_over)
        assert not event.contains(Session, name, bulk._forget)


def test_a_session_of_another_engine_cannot_defer(tmp_path):
    other = create_engine(f"sqlite:///{tmp_path / 'other.db'}")
    metadata, rows = _table()
    metadata.create_all(other)
    with pytest.raises(RuntimeError), Session(other) as session, session.begin():
        bulk.defer(session, [(rows, [{"n": 1}])])
    other.dispose()


def test_rows_deferred_in_a_transaction_closed_without_commit_are_forgotten(engine):
    metadata, rows = _table()
    metadata.create_all(engine)
    with Session(engine) as session:
        session.begin()
        bulk.defer(session, [(rows, [{"n": 1}])])
        # closed without commit: the transaction rolls back, the connection goes to the pool
    with Session(engine) as session, session.begin():
        bulk.defer(session, [(rows, [{"n": 2}])])
    with engine.connect() as connection:
        assert connection.execute(select(rows.c.n)).scalars().all() == [2]


def test_a_reader_engine_of_a_hooked_engine_may_defer(engine):
    from db.engine import reader

    metadata, rows = _table()
    metadata.create_all(engine)
    with Session(reader(engine)) as session, session.begin():
        bulk.defer(session, [(rows, [{"n": 3}])])
    with engine.connect() as connection:
        assert connection.execute(select(rows.c.n)).scalars().all() == [3]
