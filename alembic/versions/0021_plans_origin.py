"""The database a plan was created in, where not this one (issue 32)

``plans.origin``: NULL for a plan created here, which is every plan stored before. A copied
database (a second site set up from the first one's) that takes an identity of its own with
``rcb fleet identity --renew`` first writes its old identity here, so the plans it was copied
with keep exporting their models as the first database's: a third database that imports from
both then counts them once. The downgrade drops the column (the plans then export as this
database's, as before 0021).

Revision ID: 0021
Revises: 0020
Create Date: 2026-11-30 21:30:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0021"
down_revision = "0020"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.add_column("plans", sa.Column("origin", sa.String(36), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("plans") as batch:
        batch.drop_column("origin")
