"""The indexes ``rcb audit`` reads the audit log by

``rcb audit`` lists the audit log newest first, a page at a time, optionally of one action
or one actor and from a time on. ``ix_audit_log_action_at`` on ``audit_log (action, at)``
and ``ix_audit_log_actor_at`` on ``audit_log (actor, at)`` find a page of either in the same
number of rows read for a week's log as for a year's (``ix_audit_log_at``, since 0006, serves
the unfiltered list). The downgrade drops them.

Revision ID: 0024
Revises: 0023
Create Date: 2026-12-01 13:00:00
"""

from __future__ import annotations

from alembic import op

revision = "0024"
down_revision = "0023"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_index("ix_audit_log_action_at", "audit_log", ["action", "at"])
    op.create_index("ix_audit_log_actor_at", "audit_log", ["actor", "at"])


def downgrade() -> None:
    op.drop_index("ix_audit_log_actor_at", table_name="audit_log")
    op.drop_index("ix_audit_log_action_at", table_name="audit_log")
