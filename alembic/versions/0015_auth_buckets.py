"""The wrong-key allowance per client address, shared by every instance (issue 33)

``auth_buckets``: one row per client address that sent a wrong API key, the generic cell rate
algorithm's time of its bucket (:mod:`db.auth_buckets`); before, each worker process kept its
own in memory, so N instances allowed N bursts. The downgrade drops it (the workers' memory
then holds the buckets again).

Revision ID: 0015
Revises: 0014
Create Date: 2026-11-29 12:50:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0015"
down_revision = "0014"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "auth_buckets",
        sa.Column("client", sa.String(64), primary_key=True),
        sa.Column("tat_s", sa.Double(), nullable=False),
    )


def downgrade() -> None:
    op.drop_table("auth_buckets")
