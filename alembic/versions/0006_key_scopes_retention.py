"""API keys scoped to plans, their last use, and the indexes that pruning reads

``api_keys.plans`` (the plan ids a key may see; NULL: every plan, as every key before 0006),
``api_keys.last_used_at``; indexes on ``audit_log.at`` and ``idempotency_records.created_at``
so ``rcb db prune`` deletes by age without reading the whole table.

Revision ID: 0006
Revises: 0005
Create Date: 2026-11-25 03:10:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0006"
down_revision = "0005"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("api_keys") as batch:
        batch.add_column(sa.Column("plans", sa.JSON(), nullable=True))
        batch.add_column(sa.Column("last_used_at", sa.DateTime(timezone=True), nullable=True))
    op.create_index("ix_audit_log_at", "audit_log", ["at"])
    op.create_index("ix_idempotency_records_created_at", "idempotency_records", ["created_at"])


def downgrade() -> None:
    op.drop_index("ix_idempotency_records_created_at", table_name="idempotency_records")
    op.drop_index("ix_audit_log_at", table_name="audit_log")
    with op.batch_alter_table("api_keys") as batch:
        batch.drop_column("last_used_at")
        batch.drop_column("plans")
