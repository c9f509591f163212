"""A stored plan's ``coverage_k`` is at least 0.5, as a new plan's must be (issue 32)

``coverage_k`` (the catalogue band ±ΔK as k standard deviations) took any k > 0; below 0.5
the ``learn`` prior's ln K variance ``((ΔK/K)/k)²`` grew so wide that at k = 0.001 a plan's
first report overflowed, and every RCB setting is checked when a plan is read. A plan stored
with a smaller k gets 0.5 (the widest prior now taken), so that it can still be read; every
other setting is kept. The downgrade leaves the raised value (0.5 was valid before too).

Revision ID: 0017
Revises: 0016
Create Date: 2026-11-30 02:30:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0017"
down_revision = "0016"
branch_labels = None
depends_on = None

#: The least coverage_k (supervisor.rcb.settings.COVERAGE_K_LOW when this was written).
LEAST = 0.5


def upgrade() -> None:
    plans = sa.table("plans", sa.column("id", sa.Integer), sa.column("settings", sa.JSON))
    bind = op.get_bind()
    rows = bind.execute(
        sa.select(plans.c.id, plans.c.settings).where(plans.c.settings.is_not(None))
    )
    for plan_id, settings in rows.all():
        k = settings.get("coverage_k") if isinstance(settings, dict) else None
        if isinstance(k, int | float) and k < LEAST:
            raised = {**settings, "coverage_k": LEAST}
            bind.execute(sa.update(plans).where(plans.c.id == plan_id).values(settings=raised))


def downgrade() -> None:
    """Nothing to undo: 0.5 is a value the earlier code took."""
