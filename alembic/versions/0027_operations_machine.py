"""Each operation's machine, and the indexes the fleet of a tool is walked by

``operations.machine_id``: the machine of the operation's plan (a plan keeps its machine for
life), kept beside the tool so that ``ix_operations_tool_machine_plan`` on ``(tool_id,
machine_id, plan_id)`` finds one machine's newest plans with a tool newest first and stops
after :data:`supervisor.fleet.window.PLANS_PER_MACHINE` (:mod:`db.fleet_window`). Before,
the fleet's window ranked every plan that ever used the tool, and on SQLite the evidence
statement then sought each picked plan's operations among all the tool's: 13 s for a new
plan's prior over 9 760 stored plans on 32 machines (2026-12-02, docs/benchmarks.md, "A
machine's newest plans"). ``ix_operations_tool_plan`` on ``(tool_id, plan_id)`` replaces
0014's ``ix_operations_tool`` on ``(tool_id)``: a page of ``rcb fleet show TOOL`` seeks the
tool's plans after the page's cursor where it read them all. The upgrade fills the column from
``plans`` in one statement; the downgrade restores 0014's index and drops the column.

``band_states.posterior``, ``wear`` and ``monitor`` held a JSON ``null`` where a quantity had
no belief (a ``learn`` plan whose first reading of it was held back as implausible), which
``IS NOT NULL`` did not leave out: the fleet's read then decoded a missing belief and every
new plan with the tool failed (500) until the plan's next reading. They are SQL NULL now
(``JSON(none_as_null=True)``); the upgrade turns the stored JSON nulls into NULL, which the
downgrade keeps (a NULL reads as the same None).

Revision ID: 0027
Revises: 0026
Create Date: 2026-12-02 09:00:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0027"
down_revision = "0026"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("operations") as batch:
        batch.add_column(sa.Column("machine_id", sa.Integer(), nullable=True))
    op.execute(
        "UPDATE operations SET machine_id = "
        "(SELECT plans.machine_id FROM plans WHERE plans.id = operations.plan_id)"
    )
    with op.batch_alter_table("operations") as batch:
        batch.alter_column("machine_id", existing_type=sa.Integer(), nullable=False)
        batch.create_foreign_key(
            "fk_operations_machine_id_machines", "machines", ["machine_id"], ["id"]
        )
    op.create_index(
        "ix_operations_tool_machine_plan", "operations", ["tool_id", "machine_id", "plan_id"]
    )
    op.create_index("ix_operations_tool_plan", "operations", ["tool_id", "plan_id"])
    op.drop_index("ix_operations_tool", table_name="operations")
    json_type = "json_typeof" if op.get_bind().dialect.name == "postgresql" else "json_type"
    for column in ("posterior", "wear", "monitor"):
        op.execute(f"UPDATE band_states SET {column} = NULL WHERE {json_type}({column}) = 'null'")


def downgrade() -> None:
    op.create_index("ix_operations_tool", "operations", ["tool_id"])
    op.drop_index("ix_operations_tool_plan", table_name="operations")
    op.drop_index("ix_operations_tool_machine_plan", table_name="operations")
    with op.batch_alter_table("operations") as batch:
        batch.drop_constraint("fk_operations_machine_id_machines", type_="foreignkey")
        batch.drop_column("machine_id")
