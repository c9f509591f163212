"""A plan's fleet prior and the index the fleet is read by (issue 32)

``plans.prior``: the priors a plan started from where they are not the catalogue's, per
operation and quantity, with where each came from (:mod:`db.fleet`, :mod:`supervisor.fleet.
prior`); NULL for a plan that started from the catalogue (every plan stored before). The index
``ix_operations_tool`` on ``operations (tool_id)`` finds every operation of a tool, so the
fleet's evidence is read in the same number of statements for 10 plans as for 1000.
``imported_models``: learned models another database exported (``rcb models import``), one
row per operation and quantity, found by their tool's name. ``fleet_exclusions``: plans and
machines an engineer took out of the fleet (``rcb fleet exclude``); ``plans.
fleet_changes_accepted``: the changes of its process an engineer accepted when putting a
plan back (``rcb fleet include``; a plan with more counts no more). The downgrade drops them
all (a plan that started from a fleet prior keeps its learned states).

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
    op.create_table(
        "imported_models",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("tool", sa.String(200), nullable=False),
        sa.Column("body", sa.JSON(), nullable=False),
        sa.Column("source", sa.Text(), nullable=False),
        sa.Column("imported_at", sa.DateTime(timezone=True), nullable=False),
    )
    op.create_index("ix_imported_models_tool", "imported_models", ["tool"])
    op.add_column(
        "plans",
        sa.Column("fleet_changes_accepted", sa.Integer(), nullable=False, server_default="0"),
    )
    op.create_table(
        "fleet_exclusions",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("plan_id", sa.Integer(), sa.ForeignKey("plans.id"), nullable=True),
        sa.Column("machine", sa.String(200), nullable=True),
        sa.Column("reason", sa.Text(), nullable=False),
        sa.Column("actor", sa.String(200), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
    )


def downgrade() -> None:
    op.drop_table("fleet_exclusions")
    op.drop_column("plans", "fleet_changes_accepted")
    op.drop_index("ix_imported_models_tool", table_name="imported_models")
    op.drop_table("imported_models")
    op.drop_index("ix_operations_tool", table_name="operations")
    op.drop_column("plans", "prior")
