"""Each imported learned model once; this database's identity (issue 32)

``imported_models`` had one row per item of every document imported: the same document
imported twice, a newer export of the same plans, or this database's own models sent back by a
second plant were each counted again in every new plan's fleet prior, a prior narrower than
the readings behind it. The row's key is now its own columns, ``origin`` (the database that
learned it; "" where a document did not say), ``machine``, ``plan``, ``operation`` and
``quantity``, unique with its ``tool`` (``uq_imported_models_key``), and ``observations``
(its readings) says which of two is the newer. The upgrade fills them from each row's body and
keeps, of rows with one key, the one with the most readings (the last imported of equals).
``database_identity`` holds this database's identity, a UUID made here, which its exports name
as the origin of its own plans' models. The downgrade drops them (the rows kept stay).

Revision ID: 0020
Revises: 0019
Create Date: 2026-11-30 19:20:00
"""

from __future__ import annotations

import uuid
from typing import Any

import sqlalchemy as sa

from alembic import op

revision = "0020"
down_revision = "0019"
branch_labels = None
depends_on = None

_KEY = ("tool", "origin", "machine", "plan", "operation", "quantity")
_TEXT = {"origin": 36, "machine": 200, "plan": 200, "operation": 200, "quantity": 50}


def upgrade() -> None:
    for name, length in _TEXT.items():
        op.add_column(
            "imported_models",
            sa.Column(name, sa.String(length), nullable=False, server_default=""),
        )
    op.add_column(
        "imported_models",
        sa.Column("observations", sa.Integer(), nullable=False, server_default="0"),
    )
    _fill_and_keep_one()
    op.create_index("uq_imported_models_key", "imported_models", list(_KEY), unique=True)
    op.create_table(
        "database_identity",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("uuid", sa.String(36), nullable=False),
        sa.UniqueConstraint("uuid", name="uq_database_identity_uuid"),
    )
    identity = sa.table("database_identity", sa.column("id"), sa.column("uuid"))
    op.bulk_insert(identity, [{"id": 1, "uuid": str(uuid.uuid4())}])


def _fill_and_keep_one() -> None:
    """Each row's key from its body; of rows with one key, the most readings' (then newest)."""
    rows = sa.table(
        "imported_models",
        sa.column("id", sa.Integer()),
        sa.column("tool", sa.String()),
        sa.column("body", sa.JSON()),
        *(sa.column(name, sa.String()) for name in _TEXT),
        sa.column("observations", sa.Integer()),
    )
    bind = op.get_bind()
    best: dict[tuple[str, ...], tuple[int, int]] = {}
    for row_id, tool, body in bind.execute(sa.select(rows.c.id, rows.c.tool, rows.c.body)):
        values = _key_of(body)
        bind.execute(sa.update(rows).where(rows.c.id == row_id).values(**values))
        key = (tool, *(str(values[name]) for name in _TEXT))
        rank = (int(values["observations"]), int(row_id))
        if key in best and best[key] > rank:
            bind.execute(sa.delete(rows).where(rows.c.id == row_id))
            continue
        if key in best:
            bind.execute(sa.delete(rows).where(rows.c.id == best[key][1]))
        best[key] = rank


def _key_of(body: Any) -> dict[str, Any]:
    """A stored item's key columns (``supervisor.fleet.document.item_json``'s fields)."""
    posterior = body.get("posterior") or {}
    return {
        "origin": "",
        "machine": str(body.get("machine", ""))[:200],
        "plan": str(body.get("plan", ""))[:200],
        "operation": str((body.get("operation") or {}).get("name", ""))[:200],
        "quantity": str(posterior.get("quantity", ""))[:50],
        "observations": int(posterior.get("observations", 0)),
    }


def downgrade() -> None:
    op.drop_table("database_identity")
    op.drop_index("uq_imported_models_key", table_name="imported_models")
    with op.batch_alter_table("imported_models") as batch:
        for name in (*_TEXT, "observations"):
            batch.drop_column(name)
