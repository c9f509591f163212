"""Alembic environment: the metadata of db.tables, the engine of db.engine."""

from __future__ import annotations

from typing import Any

from alembic.runtime.migration import MigrationContext, MigrationInfo

from alembic import context
from db.engine import make_engine
from db.migrate import lock_in
from db.tables import Base
from db.urls import revision

config = context.config
url = config.attributes.get("url") or config.get_main_option("sqlalchemy.url")
if not url:
    raise SystemExit("rcb db: no database URL given to the migrations")

#: The migration steps this run applied (stamps are no migration and not counted).
applied: list[str] = []


def _applied(
    ctx: MigrationContext, step: MigrationInfo, heads: set[str], run_args: dict[str, Any]
) -> None:
    if step.is_migration:
        applied.append(str(step.up_revision_id))


engine = make_engine(url)
with engine.connect() as connection:
    sqlite = connection.dialect.name == "sqlite"
    if sqlite:
        # batch mode rebuilds a table (copy, drop, rename): with foreign keys enforced, dropping
        # a table other rows refer to fails (a downgrade of plans with parts). Off for the
        # migrations, outside their transaction (SQLite ignores the pragma inside one: on the
        # driver's connection, as db.engine's emit BEGIN first); references checked at the end
        connection.connection.driver_connection.execute("PRAGMA foreign_keys=OFF")
    context.configure(
        connection=connection,
        target_metadata=Base.metadata,
        render_as_batch=sqlite,
        compare_type=True,
        on_version_apply=_applied,
    )
    with context.begin_transaction():
        if connection.dialect.name == "postgresql":
            # one instance migrates at a time; the lock ends with this transaction (db.migrate)
            lock_in(connection)
            config.attributes["before"] = revision(connection)
        context.run_migrations()
        # only after a migration ran: at head nothing changed, and the check reads every row
        # with a reference (15 ms on a new database, 124 ms after a year, on every command)
        if sqlite and applied:
            broken = connection.exec_driver_sql("PRAGMA foreign_key_check").fetchall()
            if broken:
                raise SystemExit(f"rcb db: the migrations broke references: {broken[:5]}")
engine.dispose()
