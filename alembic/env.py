"""Alembic environment: the metadata of db.tables, the engine of db.engine."""

from __future__ import annotations

from alembic import context
from db.engine import make_engine
from db.migrate import lock_in
from db.tables import Base
from db.urls import revision

config = context.config
url = config.attributes.get("url") or config.get_main_option("sqlalchemy.url")
if not url:
    raise SystemExit("rcb db: no database URL given to the migrations")

engine = make_engine(url)
with engine.connect() as connection:
    context.configure(
        connection=connection,
        target_metadata=Base.metadata,
        render_as_batch=connection.dialect.name == "sqlite",
        compare_type=True,
    )
    with context.begin_transaction():
        if connection.dialect.name == "postgresql":
            # one instance migrates at a time; the lock ends with this transaction (db.migrate)
            lock_in(connection)
            config.attributes["before"] = revision(connection)
        context.run_migrations()
engine.dispose()
