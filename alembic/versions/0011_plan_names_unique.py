"""A plan's name names one plan: a unique index on ``plans.name`` (issue 30)

``rcb history NAME`` and the other PLAN arguments take a plan's name as well as its id
(:func:`api.services.plans.resolve_plan`), and a second ``POST /plans`` or ``rcb plans create``
with a stored name is refused (409 ``plan_name_taken``). There is no retired plan: the name is
unique among all plans.

A database may already hold several plans of one name (nothing refused them before). The
oldest of them (the lowest id) keeps the name; each later one is renamed ``NAME#ID`` (its own
id; cut so that it fits the 200 characters of the column, and given more ``#`` in the unlikely
case that such a name is taken too). No plan, part or setpoint is lost or changed otherwise, ids
stay what they were, so an MES that posts by id goes on unaffected; ``rcb plans`` shows the new
names. The downgrade drops the index and leaves the names as they are.

Revision ID: 0011
Revises: 0010
Create Date: 2026-11-27 19:00:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0011"
down_revision = "0010"
branch_labels = None
depends_on = None

#: The length of ``plans.name``.
NAME_LENGTH = 200


def renamed(name: str, plan_id: int, taken: set[str]) -> str:
    """``NAME#ID`` within :data:`NAME_LENGTH` characters, not in ``taken``."""
    suffix = f"#{plan_id}"
    while True:
        candidate = name[: NAME_LENGTH - len(suffix)] + suffix
        if candidate not in taken:
            return candidate
        suffix = "#" + suffix


def upgrade() -> None:
    plans = sa.table("plans", sa.column("id", sa.Integer), sa.column("name", sa.String))
    bind = op.get_bind()
    rows = bind.execute(sa.select(plans.c.id, plans.c.name).order_by(plans.c.id)).all()
    taken = {name for _, name in rows}
    seen: set[str] = set()
    for plan_id, name in rows:
        if name not in seen:
            seen.add(name)
            continue
        new = renamed(name, plan_id, taken)
        taken.add(new)
        bind.execute(sa.update(plans).where(plans.c.id == plan_id).values(name=new))
    op.create_index("ix_plans_name", "plans", ["name"], unique=True)


def downgrade() -> None:
    op.drop_index("ix_plans_name", table_name="plans")
