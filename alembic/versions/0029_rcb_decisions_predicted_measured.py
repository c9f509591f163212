"""Each RCB decision's prediction and the value it judged

``rcb_decisions.predicted``: the model's prediction at the setpoint the part was made with;
``rcb_decisions.measured``: the value the decision judged (for a spindle-load reading, the
force converted from it). A part's report answered both (``updates``), but the stored
decision kept neither: reading the part back (``GET /plans/{id}/parts``, ``rcb parts
--json``, ``rcb export``, the report) gave null where the report had given numbers. Nullable:
decisions stored before 0029 have none and read back null, as before. The downgrade drops
both.

Revision ID: 0029
Revises: 0028
Create Date: 2026-12-03 09:00:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0029"
down_revision = "0028"
branch_labels = None
depends_on = None

#: The new columns, in the order of the table (db.tables.RcbDecision).
COLUMNS = ("predicted", "measured")


def upgrade() -> None:
    with op.batch_alter_table("rcb_decisions") as batch:  # on SQLite an ALTER TABLE, no copy
        for name in COLUMNS:
            batch.add_column(sa.Column(name, sa.Double(), nullable=True))


def downgrade() -> None:
    # SQLite copies the table; its indexes come back as reflected, the partial one with its
    # WHERE (tests/db/test_migration_0029.py)
    with op.batch_alter_table("rcb_decisions") as batch:
        for name in reversed(COLUMNS):
            batch.drop_column(name)
