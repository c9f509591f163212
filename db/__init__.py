"""Persistence (SQLAlchemy 2.0): the tables and the functions that read and write them.

Every function takes a session (keyword-only) and leaves the transaction to its caller
(:mod:`api.services`).

- :mod:`db.tables`: the typed tables (append-only history; migrations in ``alembic/``).
- :mod:`db.engine`: engines for SQLite and PostgreSQL, read-only variants, migrations.
- :mod:`db.plans`: plans, their replans, operations and setpoint versions.
- :mod:`db.model_versions`: the versions of each operation's models.
- :mod:`db.state`: a plan's RCB state loaded from the tables.
- :mod:`db.state_cache`: loaded states kept in process, keyed on ``plans.state_token``.
- :mod:`db.plan_state`: a plan's RCB settings and halt as the JSON of their columns.
- :mod:`db.parts`: a part's record (measurements, decisions), parts counted.
- :mod:`db.store_report`: an accepted part report stored: its record, band states, model
  versions, setpoints and the plan's new pointers (the one place they are written).
- :mod:`db.intake`: a part report's first step: the plan locked, the part's row, a stored answer.
- :mod:`db.library`: tools and their baseline models.
- :mod:`db.read`: what the read use cases read, by resource (plans, parts, history, record).
- :mod:`db.api_keys`, :mod:`db.audit`, :mod:`db.idempotency`: API keys, the audit log (and
  pruning), idempotency records.
- :mod:`db.keylock`: which idempotency keys are in flight, on SQLite (file locks).
- :mod:`db.bulk`: many rows inserted and updated in one statement (PostgreSQL).
- :mod:`db.errors`: the errors db raises.
"""
