"""Every RCB setting of a plan in one JSON column, strategy and alpha included (issue 31)

``plans.settings`` gains the keys ``strategy`` and ``alpha`` from the columns of those names,
which are dropped; a NULL ``settings`` (a plan stored before 0005) becomes a table of those two
(every other key missing: the default, as before). The settings are declared once in
:mod:`supervisor.rcb.settings`; a new setting is a new key, no migration. The downgrade adds
the two columns back, fills them from the keys (the defaults of 0005 where a key is missing)
and removes the keys.

Revision ID: 0013
Revises: 0012
Create Date: 2026-11-28 01:00:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0013"
down_revision = "0012"
branch_labels = None
depends_on = None

#: The two columns and the defaults they had (0001: the ORM's ``learn`` and 0.25).
COLUMNS = {"strategy": "learn", "alpha": 0.25}

# Plain ALTER TABLE, no batch: SQLite (3.35 and later) drops a column in place, where a batch
# would copy plans and trip the foreign keys of every table that references it.


def _plans() -> sa.TableClause:
    return sa.table(
        "plans",
        sa.column("id", sa.Integer),
        sa.column("strategy", sa.String),
        sa.column("alpha", sa.Double),
        sa.column("settings", sa.JSON),
    )


def upgrade() -> None:
    plans = _plans()
    bind = op.get_bind()
    rows = bind.execute(sa.select(plans.c.id, plans.c.strategy, plans.c.alpha, plans.c.settings))
    for plan_id, strategy, alpha, settings in rows.all():
        merged = {"strategy": strategy, "alpha": alpha, **(settings or {})}
        bind.execute(sa.update(plans).where(plans.c.id == plan_id).values(settings=merged))
    op.drop_column("plans", "alpha")
    op.drop_column("plans", "strategy")


def downgrade() -> None:
    op.add_column(
        "plans",
        sa.Column("strategy", sa.String(length=20), nullable=False, server_default="learn"),
    )
    op.add_column("plans", sa.Column("alpha", sa.Double(), nullable=False, server_default="0.25"))
    plans = _plans()
    bind = op.get_bind()
    for plan_id, settings in bind.execute(sa.select(plans.c.id, plans.c.settings)).all():
        rest = {k: v for k, v in (settings or {}).items() if k not in COLUMNS}
        values = {k: (settings or {}).get(k, default) for k, default in COLUMNS.items()}
        bind.execute(sa.update(plans).where(plans.c.id == plan_id).values(settings=rest, **values))
