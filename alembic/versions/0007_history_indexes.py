"""Indexes that keep history reads linear in the page, not in the plan's life (issue 17)

``operation_model_versions (operation_id, quantity, part_id)`` and
``(operation_id, part_id, quantity)``: the model in force at a setpoint version, and the
part-less versions, are index seeks; ``rcb_decisions (part_id)``: a page
of parts reads its decisions without a scan; ``parts (plan_id, received_at)``: ``rcb parts
--since``.

Revision ID: 0007
Revises: 0006
Create Date: 2026-11-25 03:30:00
"""

from __future__ import annotations

from alembic import op

revision = "0007"
down_revision = "0006"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_index(
        "ix_operation_model_versions_quantity_part",
        "operation_model_versions",
        ["operation_id", "quantity", "part_id"],
    )
    op.create_index(
        "ix_operation_model_versions_part",
        "operation_model_versions",
        ["operation_id", "part_id", "quantity"],
    )
    op.create_index("ix_rcb_decisions_part_id", "rcb_decisions", ["part_id"])
    op.create_index("ix_parts_plan_received", "parts", ["plan_id", "received_at"])


def downgrade() -> None:
    op.drop_index("ix_parts_plan_received", table_name="parts")
    op.drop_index("ix_rcb_decisions_part_id", table_name="rcb_decisions")
    op.drop_index("ix_operation_model_versions_part", table_name="operation_model_versions")
    op.drop_index(
        "ix_operation_model_versions_quantity_part", table_name="operation_model_versions"
    )
