"""Whether a plan's pending change of its process was confirmed by its readings (issue 32)

``plans.fleet_change_confirmed``: true once the part :mod:`db.fleet_changes` judges a change
at (five parts after ``plans.fleet_change_part``) found the readings confirm it; the plan then
waits out of the fleet for an engineer (``rcb fleet include``). It spares every later report
of the plan a count of its parts to learn that the change was judged already, and lets
``rcb fleet show`` tell a change still to be judged from one confirmed. The upgrade marks a
pending change confirmed where more than six parts were made from its part on (under 0022 an
unconfirmed change was cleared at its sixth); the downgrade drops the column.

Revision ID: 0023
Revises: 0022
Create Date: 2026-12-01 06:30:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0023"
down_revision = "0022"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.add_column(
        "plans",
        sa.Column(
            "fleet_change_confirmed", sa.Boolean(), nullable=False, server_default=sa.false()
        ),
    )
    op.execute(
        "UPDATE plans SET fleet_change_confirmed = true WHERE fleet_change_part IS NOT NULL "
        "AND (SELECT count(*) FROM parts WHERE parts.plan_id = plans.id "
        "AND parts.id >= plans.fleet_change_part) > 6"
    )


def downgrade() -> None:
    with op.batch_alter_table("plans") as batch:
        batch.drop_column("fleet_change_confirmed")
