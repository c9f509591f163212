"""Reads do not starve writes: the readers have their own, bounded pool (issue 17 item 3).

Four viewers reading history cut one MES client's reports a hundredfold; the reads shared the
writers' pool (on PostgreSQL they could hold every connection). The mixed-load figures are
``benchmarks/mixed_load.py``'s (README).
"""

from __future__ import annotations

import pytest
from sqlalchemy import text
from sqlalchemy.exc import TimeoutError as PoolTimeout
from sqlalchemy.orm import Session

from db import engine as engines
from db.engine import READ_POOL_SIZE, one_statement_reader, reader


def test_readers_have_their_own_bounded_pool(engine):
    read = reader(engine)
    assert read is reader(engine)  # one read pool per engine (per worker)
    assert read.pool is not engine.pool and read.pool.size() == READ_POOL_SIZE == 1
    held = [read.connect() for _ in range(READ_POOL_SIZE)]
    try:
        with pytest.raises(PoolTimeout):  # no overflow: a further read waits for one
            read.pool._timeout = 0.2  # type: ignore[attr-defined]
            read.connect()
        # the readers hold every read connection; a report still writes, a key is still read
        with Session(engine) as session, session.begin():
            assert session.execute(text("SELECT 1")).scalar() == 1
        with Session(one_statement_reader(engine)) as session:
            assert session.execute(text("SELECT 1")).scalar() == 1
    finally:
        read.pool._timeout = engines.READ_POOL_TIMEOUT_S  # type: ignore[attr-defined]
        for connection in held:
            connection.close()


def test_a_read_sees_what_was_committed_and_opens_no_write_lock(engine):
    with Session(engine) as session, session.begin():
        session.execute(text("CREATE TABLE seen (n INTEGER)"))
        session.execute(text("INSERT INTO seen VALUES (7)"))
    with Session(reader(engine)) as reading, reading.begin():
        assert reading.execute(text("SELECT n FROM seen")).scalar() == 7
        # a read transaction open: a writer still commits at once (SQLite: WAL, deferred BEGIN)
        with Session(engine) as writing, writing.begin():
            writing.execute(text("INSERT INTO seen VALUES (8)"))
    with Session(reader(engine)) as reading:
        assert reading.execute(text("SELECT count(*) FROM seen")).scalar() == 2


def test_disposing_the_engine_disposes_its_read_pool(engine):
    read = reader(engine)
    read.connect().close()
    assert read.pool.checkedin() == 1
    engine.dispose()
    assert read.pool.checkedin() == 0
