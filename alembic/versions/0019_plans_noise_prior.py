"""A plan's noise prior from the fleet (issue 32)

``plans.noise_prior``: per quantity, the noise scale's prior of the measuring chain that reads
it where a plan started from what the fleet's chains showed (:mod:`supervisor.fleet.noise`):
its inverse-gamma ``shape`` and ``rate`` and where it came from, and the part whose readings
let it go (:mod:`supervisor.rcb.noise_check`) once one did; NULL for a plan whose chains start
from the default (every plan stored before). The downgrade drops it (a plan then counts its
readings at the default's noise from its next report).

Revision ID: 0019
Revises: 0018
Create Date: 2026-11-30 04:30:00
"""

from __future__ import annotations

import sqlalchemy as sa

from alembic import op

revision = "0019"
down_revision = "0018"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.add_column("plans", sa.Column("noise_prior", sa.JSON(none_as_null=True), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("plans") as batch:
        batch.drop_column("noise_prior")
