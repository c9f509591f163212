"""What RCB watches in the readings per operation and quantity (issue 27)

``band_states.monitor`` (:meth:`supervisor.rcb.monitor_state.Monitor.to_json`): the noise scale's
belief, the last reading learned from and a quarantined reading waiting for confirmation. NULL
for rows stored before this revision (their plans start from the reported noise).

Revision ID: 0010
Revises: 0009
Create Date: 2026-11-26 19:00:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0010"
down_revision = "0009"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("band_states") as batch:
        batch.add_column(sa.Column("monitor", sa.JSON(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("band_states") as batch:
        batch.drop_column("monitor")
