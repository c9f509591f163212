"""A machine's limits are one JSON column keyed by quantity (issue 31)

``machines.limits`` replaces the four columns ``max_power_kW``, ``max_spindle_rpm``,
``max_torque_Nm`` and ``max_feed_rate_mm_min``: ``{"power_kW": 22.0, "spindle_rpm": 4000.0}``,
a quantity absent where its column was NULL. A new machine-limited quantity of the registry
(:mod:`models.quantities`) is a new key, no migration. The downgrade writes the four columns
back from the keys it knows; a limit on any other quantity has no column there and is dropped.

The names are written out here, not read from the registry: a migration is what the schema was
at its revision, whatever the registry holds later.

Revision ID: 0012
Revises: 0011
Create Date: 2026-11-28 00:30:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0012"
down_revision = "0011"
branch_labels = None
depends_on = None

#: The columns of 0001 and the quantity each bounds.
COLUMNS = {
    "max_power_kW": "power_kW",
    "max_spindle_rpm": "spindle_rpm",
    "max_torque_Nm": "torque_Nm",
    "max_feed_rate_mm_min": "feed_rate_mm_min",
}


def _machines(*extra: sa.ColumnClause[object]) -> sa.TableClause:
    return sa.table("machines", sa.column("id", sa.Integer), *extra)


# Plain ALTER TABLE, no batch: SQLite (3.35 and later) adds a NOT NULL column with a constant
# default and drops a column in place, where a batch would copy the table and trip the
# foreign keys of the plans that reference it.


def upgrade() -> None:
    limits = sa.Column("limits", sa.JSON(), nullable=False, server_default="{}")
    op.add_column("machines", limits)
    old = _machines(*(sa.column(c, sa.Double) for c in COLUMNS), sa.column("limits", sa.JSON))
    bind = op.get_bind()
    for row in bind.execute(sa.select(old)).mappings().all():
        values = {q: float(row[c]) for c, q in COLUMNS.items() if row[c] is not None}
        bind.execute(sa.update(old).where(old.c.id == row["id"]).values(limits=values))
    for column in COLUMNS:
        op.drop_column("machines", column)


def downgrade() -> None:
    for column in COLUMNS:
        op.add_column("machines", sa.Column(column, sa.Double(), nullable=True))
    new = _machines(*(sa.column(c, sa.Double) for c in COLUMNS), sa.column("limits", sa.JSON))
    bind = op.get_bind()
    for row in bind.execute(sa.select(new.c.id, new.c.limits)).all():
        limits = row.limits or {}
        values = {c: limits.get(q) for c, q in COLUMNS.items()}
        bind.execute(sa.update(new).where(new.c.id == row.id).values(**values))
    op.drop_column("machines", "limits")
