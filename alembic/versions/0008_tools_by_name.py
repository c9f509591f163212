"""Tool names in code-point order on PostgreSQL: GET /tools pages by name (issue 17)

``GET /tools`` merges the stored tools with the packaged catalogue by name as Python sorts
it (code points). SQLite compares text so already; PostgreSQL compares by the database's
collation, so ``tools.name`` gets the collation ``"C"`` there (its unique index is rebuilt
with it): a page is then a range read of that index.

Revision ID: 0008
Revises: 0007
Create Date: 2026-11-26 09:00:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0008"
down_revision = "0007"
branch_labels = None
depends_on = None


def upgrade() -> None:
    if op.get_bind().dialect.name == "postgresql":
        op.alter_column(
            "tools",
            "name",
            type_=sa.String(200, collation="C"),
            existing_type=sa.String(200),
            existing_nullable=False,
        )


def downgrade() -> None:
    if op.get_bind().dialect.name == "postgresql":
        op.alter_column(
            "tools",
            "name",
            type_=sa.String(200),
            existing_type=sa.String(200, collation="C"),
            existing_nullable=False,
        )
