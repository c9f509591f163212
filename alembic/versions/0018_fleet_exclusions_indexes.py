"""Indexes on the fleet's exclusions by plan and by machine (issue 32)

The fleet's reads (:mod:`db.fleet`, :mod:`db.fleet_members`) ask, for every operation row,
whether an engineer took its plan or its machine out: with these, a seek each instead of a
scan of every exclusion an engineer ever made. The downgrade drops them.

Revision ID: 0018
Revises: 0017
Create Date: 2026-11-30 02:50:00
"""

from __future__ import annotations

from alembic import op

revision = "0018"
down_revision = "0017"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_index("ix_fleet_exclusions_plan", "fleet_exclusions", ["plan_id"])
    op.create_index("ix_fleet_exclusions_machine", "fleet_exclusions", ["machine"])


def downgrade() -> None:
    op.drop_index("ix_fleet_exclusions_machine", table_name="fleet_exclusions")
    op.drop_index("ix_fleet_exclusions_plan", table_name="fleet_exclusions")
