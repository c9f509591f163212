"""Migration 0031: ``ix_imported_models_machine_id``, the index each imported machine's newest
models are walked by (``db.fleet_window.newest_imported``). Upgraded, the schema is the
tables'; the walk reads the index (SQLite's plan says so); the downgrade drops it and keeps
the rows, and upgrading again works."""

from __future__ import annotations

from sqlalchemy import insert, inspect, select
from sqlalchemy.orm import Session
from test_migration_0012 import _downgrade
from test_migrations import _no_difference

from db import tables as t
from db.engine import make_engine, upgrade
from db.fleet_window import newest_imported

INDEX = "ix_imported_models_machine_id"


def _indexes(url: str) -> set[str]:
    engine = make_engine(url)
    try:
        with engine.connect() as connection:
            return {i["name"] for i in inspect(connection).get_indexes("imported_models")}
    finally:
        engine.dispose()


def test_0031_up_down_and_the_walk_reads_the_index(backend_url):
    upgrade(backend_url)
    _no_difference(backend_url)
    assert INDEX in _indexes(backend_url)
    engine = make_engine(backend_url)
    row = {"tool": "T", "origin": "", "machine": "m", "operation": "o", "quantity": "force_N"}
    with Session(engine) as session, session.begin():
        session.execute(
            insert(t.core_table(t.ImportedModel)),
            [{**row, "plan": f"p{i}", "body": {}, "source": "a.json"} for i in range(12)],
        )
    dialect = engine.dialect.name
    with Session(engine) as session:
        window = select(newest_imported(["T"], dialect))
        picked = sorted(plan for *_, plan in session.execute(window))
        if dialect == "sqlite":
            sql = str(window.compile(engine, compile_kwargs={"literal_binds": True}))
            plan = [
                r[-1] for r in session.connection().exec_driver_sql(f"EXPLAIN QUERY PLAN {sql}")
            ]
            assert any(INDEX in line for line in plan), plan
    engine.dispose()
    assert picked == sorted(f"p{i}" for i in range(2, 12))  # the 10 imported last
    _downgrade(backend_url, "0030")
    assert INDEX not in _indexes(backend_url)
    upgrade(backend_url)
    _no_difference(backend_url)
