"""The part a plan's pending change of its process was counted at (issue 32)

``plans.fleet_change_part``: the id of the part at which the plan's monitors counted a change
of its process beyond those an engineer accepted (``plans.fleet_changes_accepted``). What the
plan had learned before that part is compared with what it learned since
(:mod:`db.fleet_changes`): where the readings since confirm the change the plan is out of the
fleet, where they do not (a monitor's false alarm) it stays in. ``rcb fleet include`` accepts
the change and clears it; ``rcb replan --reset-bands`` clears it with the count of changes.
NULL: no change pending, which is every plan stored before; a plan stored before with a change
not accepted stays out of the fleet, as it was. The downgrade drops the column (every change
not accepted then keeps its plan out, as before 0022).

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
    op.add_column("plans", sa.Column("fleet_change_part", sa.Integer(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("plans") as batch:
        batch.drop_column("fleet_change_part")
