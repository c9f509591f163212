"""A stored plan's ``z`` is at least 1, as a new plan's must be (issue 32)

``z`` (the ``learn`` cone's multiple of the posterior's standard deviation) took any value
from 0.5; under 1 a setpoint in force was kept past its limit and the plan stopped at its
second part (``supervisor.optimize.optimizer.KEEP_Z_FLOOR``), so a plan now refuses it, and
every RCB setting is checked when a plan is read: a plan stored with a smaller ``z`` could no
longer be read. It gets 1, the least now taken; every other setting is kept. Each raise is
written to the audit log (actor ``migration 0025``, action ``raise z``, the old value in its
detail), so ``rcb audit --action 'raise z'`` shows the plans it touched. The downgrade leaves
the raised value (1 was valid before too) and the entries.

Revision ID: 0025
Revises: 0024
Create Date: 2026-12-01 16:00:00
"""

from __future__ import annotations

from datetime import UTC, datetime

import sqlalchemy as sa

from alembic import op

revision = "0025"
down_revision = "0024"
branch_labels = None
depends_on = None

#: The least z (supervisor.optimize.optimizer.KEEP_Z_FLOOR when this was written).
LEAST = 1.0


def upgrade() -> None:
    plans = sa.table("plans", sa.column("id", sa.Integer), sa.column("settings", sa.JSON))
    audit = sa.table(
        "audit_log",
        sa.column("at", sa.DateTime(timezone=True)),
        sa.column("actor", sa.String),
        sa.column("action", sa.String),
        sa.column("target", sa.Text),
        sa.column("result", sa.String),
        sa.column("detail", sa.JSON),
    )
    bind = op.get_bind()
    rows = bind.execute(
        sa.select(plans.c.id, plans.c.settings).where(plans.c.settings.is_not(None))
    )
    for plan_id, settings in rows.all():
        z = settings.get("z") if isinstance(settings, dict) else None
        if isinstance(z, int | float) and not isinstance(z, bool) and z < LEAST:
            raised = {**settings, "z": LEAST}
            bind.execute(sa.update(plans).where(plans.c.id == plan_id).values(settings=raised))
            bind.execute(
                sa.insert(audit).values(
                    at=datetime.now(UTC),
                    actor="migration 0025",
                    action="raise z",
                    target=f"plan {plan_id}",
                    result=str(LEAST),
                    detail={"z_was": z, "z": LEAST, "reason": "z under 1 is refused"},
                )
            )


def downgrade() -> None:
    """Nothing to undo: 1 is a value the earlier code took."""
