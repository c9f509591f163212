"""plan_revisions: an engineer's replans (plan structure, changes, who)

Revision ID: 0003
Revises: 0002
Create Date: 2026-11-22 05:40:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "plan_revisions",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("plan_id", sa.Integer(), nullable=False),
        sa.Column("setpoint_version", sa.Integer(), nullable=False),
        sa.Column("body", sa.JSON(), nullable=False),
        sa.Column("changes", sa.JSON(), nullable=False),
        sa.Column("reset_bands", sa.Boolean(), nullable=False),
        sa.Column("bands_reset_after_part", sa.Integer(), nullable=True),
        sa.Column("actor", sa.String(length=200), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.ForeignKeyConstraint(
            ["plan_id"], ["plans.id"], name=op.f("fk_plan_revisions_plan_id_plans")
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_plan_revisions")),
        sa.UniqueConstraint(
            "plan_id", "setpoint_version", name=op.f("uq_plan_revisions_plan_id_setpoint_version")
        ),
    )


def downgrade() -> None:
    op.drop_table("plan_revisions")
