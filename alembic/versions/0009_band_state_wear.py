"""The rise per part an edge makes, learned per operation and wearing quantity (issue 15)

``band_states.wear`` (:meth:`supervisor.rcb.wear.WearRise.to_json`): the belief on the rise
and the current edge's last reading, which the band law projects a reading to the edge's last
part with. NULL for a quantity that does not wear, an operation without a ``parts_per_edge``
limit, and rows stored before this revision (their plans start from the prior).

Revision ID: 0009
Revises: 0008
Create Date: 2026-11-25 20:00:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0009"
down_revision = "0008"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("band_states") as batch:
        batch.add_column(sa.Column("wear", sa.JSON(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("band_states") as batch:
        batch.drop_column("wear")
