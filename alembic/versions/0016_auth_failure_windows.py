"""The audit windows of authentication failures, counted over every instance (issue 33)

``auth_failure_windows``: one row per client address, action, reason and audit window, the
failures every instance counted in it and the audit entry that shows their sum
(:mod:`db.audit_windows`); before, each worker process kept its own count and row, so a
burst spread over N workers was N rows. The downgrade drops it (each worker then counts in
its memory again).

Revision ID: 0016
Revises: 0015
Create Date: 2026-11-29 15:10:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0016"
down_revision = "0015"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "auth_failure_windows",
        sa.Column("client", sa.String(64), primary_key=True),
        sa.Column("action", sa.String(100), primary_key=True),
        sa.Column("reason", sa.String(50), primary_key=True),
        sa.Column("window_start_s", sa.Double(), primary_key=True),
        sa.Column("count", sa.Integer(), nullable=False),
        sa.Column("audit_id", sa.Integer(), nullable=True),
    )


def downgrade() -> None:
    op.drop_table("auth_failure_windows")
