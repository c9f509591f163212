"""The indexes a plan's report finds its newest and its marked RCB decisions by, and a page
of a plan's parts

``ix_parts_plan_id`` on ``(plan_id, id)``: a page of ``GET /plans/{id}/parts`` (oldest or
newest first) is a seek; SQLite took ``ix_parts_plan_received`` and sorted every part of the
plan for each page.

``ix_rcb_decisions_operation_quantity_part`` on ``(operation_id, quantity, part_id)``: the
newest decision of each of a plan's operations and quantities is one seek of the index's
end (``db.read.record.last_decisions``); it grouped every decision the plan ever made.
``ix_rcb_decisions_marked`` on ``(operation_id, flagged, flag, note)`` holds only the decisions
that were flagged or carry a note: the report's totals of flags, breaches, notes and readings
to check read those, not every decision (``db.read.record.decision_totals``). A year's review
measured both growing with the plan's parts (8 000 parts: 8 and 13 ms, from 1.5 and 2.2 ms at
800).

Revision ID: 0028
Revises: 0027
Create Date: 2026-12-02 12:00:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0028"
down_revision = "0027"
branch_labels = None
depends_on = None

#: The decisions the partial index holds, as each dialect renders SQLAlchemy's
#: ``or_(flagged, note.is_not(None))`` (SQLite matches a partial index by the words; db.tables
#: says the same).
MARKED = {"postgresql": "flagged OR note IS NOT NULL", "sqlite": "flagged = 1 OR note IS NOT NULL"}


def upgrade() -> None:
    op.create_index("ix_parts_plan_id", "parts", ["plan_id", "id"])
    op.create_index(
        "ix_rcb_decisions_operation_quantity_part",
        "rcb_decisions",
        ["operation_id", "quantity", "part_id"],
    )
    op.create_index(
        "ix_rcb_decisions_marked",
        "rcb_decisions",
        ["operation_id", "flagged", "flag", "note"],  # covering: the totals read no row
        postgresql_where=sa.text(MARKED["postgresql"]),
        sqlite_where=sa.text(MARKED["sqlite"]),
    )


def downgrade() -> None:
    op.drop_index("ix_rcb_decisions_marked", table_name="rcb_decisions")
    op.drop_index("ix_rcb_decisions_operation_quantity_part", table_name="rcb_decisions")
    op.drop_index("ix_parts_plan_id", table_name="parts")
