"""The fleet's own tables: imported models, the database's identity, exclusions (issue 32).

Re-exported by :mod:`db.tables` (``t.ImportedModel`` ...), where the rest of the schema is.
"""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import ForeignKey, Index, String, Text
from sqlalchemy.orm import Mapped, mapped_column

from db.table_base import Base, utcnow


class ImportedModel(Base):
    """A learned model another database exported (``rcb models import``, :mod:`db.fleet`).

    ``body``: one item of the document (:func:`supervisor.fleet.document.item_json`);
    ``source``: where it came from (the file's name and the exporting plan). One row per
    learned model (``uq_imported_models_key``: the database that learned it, ``origin``, ""
    where a document did not say, its machine, plan, operation and quantity), so a document
    imported twice, or a newer export of the same plans, counts each model once (alembic 0020);
    each machine's newest models are walked by ``ix_imported_models_machine_id`` (0031).
    """

    __tablename__ = "imported_models"
    __table_args__ = (
        Index("ix_imported_models_tool", "tool"),
        Index("ix_imported_models_machine_id", "tool", "origin", "machine", "id"),  # 0031
        Index(
            "uq_imported_models_key",
            "tool",
            "origin",
            "machine",
            "plan",
            "operation",
            "quantity",
            unique=True,
        ),  # fmt: skip
    )
    id: Mapped[int] = mapped_column(primary_key=True)
    tool: Mapped[str] = mapped_column(String(200))
    body: Mapped[dict[str, Any]]
    source: Mapped[str] = mapped_column(Text)
    imported_at: Mapped[datetime] = mapped_column(default=utcnow)
    origin: Mapped[str] = mapped_column(String(36), server_default="")
    machine: Mapped[str] = mapped_column(String(200), server_default="")
    plan: Mapped[str] = mapped_column(String(200), server_default="")
    operation: Mapped[str] = mapped_column(String(200), server_default="")
    quantity: Mapped[str] = mapped_column(String(50), server_default="")
    #: The posterior's readings: of two exports of one model, the one with more is kept.
    observations: Mapped[int] = mapped_column(server_default="0")


class DatabaseIdentity(Base):
    """The database's identity, one row: what its exports say they came from (alembic 0020).

    An export names each learned model's ``origin``; an import skips the models whose plan the
    importing database holds under that origin (its own plans already count), so a model that
    travels there and back is not counted twice (:mod:`db.fleet_models`).
    """

    __tablename__ = "database_identity"
    id: Mapped[int] = mapped_column(primary_key=True)
    uuid: Mapped[str] = mapped_column(String(36), unique=True)


class FleetExclusion(Base):
    """A plan or a machine an engineer took out of the fleet (``rcb fleet exclude``)."""

    __tablename__ = "fleet_exclusions"
    __table_args__ = (  # what the fleet's reads look up per row (db.fleet, alembic 0018)
        Index("ix_fleet_exclusions_plan", "plan_id"),
        Index("ix_fleet_exclusions_machine", "machine"),
    )
    id: Mapped[int] = mapped_column(primary_key=True)
    plan_id: Mapped[int | None] = mapped_column(ForeignKey("plans.id"))
    machine: Mapped[str | None] = mapped_column(String(200))
    reason: Mapped[str] = mapped_column(Text)
    actor: Mapped[str] = mapped_column(String(200))
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
