"""A plan's fleet prior and the index the fleet is read by (issue 32)

``plans.prior``: the priors a plan started from where they are not the catalogue's, per
operation and quantity, with where each came from (:mod:`db.fleet`, :mod:`supervisor.fleet.
prior`); NULL for a plan that started from the catalogue (every plan stored before). The index
``ix_operations_tool`` on ``operations (tool_id)`` finds every operation of a tool, so the
fleet's evidence is read in the same number of statements for 10 plans as for 1000. The
downgrade drops both (a plan that started from a fleet prior keeps its learned states).

Revision ID: 0014
Revises: 0013
Create Date: 2026-11-28 01:30:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0014"
down_revision = "0013"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.add_column("plans", sa.Column("prior", sa.JSON(none_as_null=True), nullable=True))
    op.create_index("ix_operations_tool", "operations", ["tool_id"])


def downgrade() -> None:
    op.drop_index("ix_operations_tool", table_name="operations")
    op.drop_column("plans", "prior")
