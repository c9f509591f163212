"""Decision flags and notes, every RCB setting of a plan, the halt, the learn posterior

``rcb_decisions.flag`` (``breach``, ``above_band``, ``below_band``) and ``.note`` (the
one-sided law's information only); ``plans.settings`` (floors, coverage_k, discrepancy, z,
exponent_sd; NULL for older plans: the defaults), ``plans.halt`` (the conflicts of a halted
plan, NULL while it runs); ``band_states.posterior`` (the ``learn`` strategy's belief).

Revision ID: 0005
Revises: 0004
Create Date: 2026-11-23 09:00:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0005"
down_revision = "0004"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("rcb_decisions") as batch:
        batch.add_column(sa.Column("flag", sa.String(length=20), nullable=True))
        batch.add_column(sa.Column("note", sa.String(length=20), nullable=True))
    with op.batch_alter_table("plans") as batch:
        batch.add_column(sa.Column("settings", sa.JSON(), nullable=True))
        batch.add_column(sa.Column("halt", sa.JSON(), nullable=True))
    with op.batch_alter_table("band_states") as batch:
        batch.add_column(sa.Column("posterior", sa.JSON(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("band_states") as batch:
        batch.drop_column("posterior")
    with op.batch_alter_table("plans") as batch:
        batch.drop_column("halt")
        batch.drop_column("settings")
    with op.batch_alter_table("rcb_decisions") as batch:
        batch.drop_column("note")
        batch.drop_column("flag")
