"""Where a plan's evidence for the fleet stops: the part its process changed at (issue 32)

``plans.fleet_evidence_before_part``: the id of the part at which the plan's monitors counted a
change of its process beyond those an engineer accepted (``plans.fleet_changes_accepted``);
the fleet keeps what the plan learned before that part and leaves out what it learned since,
until ``rcb fleet include`` accepts the change (which clears it) or ``rcb replan
--reset-bands`` starts the count again. NULL: no change pending, which is every plan stored
before; a plan stored before with a change not accepted stays out of the fleet whole, as it
was. The downgrade drops the column (a changed plan is then out whole, as before 0022).

Revision ID: 0022
Revises: 0021
Create Date: 2026-12-01 03:00:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0022"
down_revision = "0021"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.add_column("plans", sa.Column("fleet_evidence_before_part", sa.Integer(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("plans") as batch:
        batch.drop_column("fleet_evidence_before_part")
