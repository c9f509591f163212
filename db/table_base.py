"""The declarative base of every table: naming convention, column types, the clock.

:mod:`db.tables` (the plans, models and parts) and :mod:`db.access_tables` (keys, audit,
limits) both derive from it, so one ``Base.metadata`` holds them all for Alembic.
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any, cast

from sqlalchemy import JSON, DateTime, MetaData, Table
from sqlalchemy.orm import DeclarativeBase

from models.bounds import LARGEST_WHOLE

#: Stable constraint names, so Alembic migrations name them the same on every database.
NAMING_CONVENTION = {
    "ix": "ix_%(column_0_label)s",
    "uq": "uq_%(table_name)s_%(column_0_N_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}

#: The largest value an integer column holds (PostgreSQL's ``integer``: 32 bits): every id,
#: version and count the service takes is bounded by it (:data:`models.bounds.LARGEST_WHOLE`).
MAX_INT = LARGEST_WHOLE


def utcnow() -> datetime:
    """Timezone-aware current time (stored as UTC)."""
    return datetime.now(UTC)


def as_utc(moment: datetime) -> datetime:
    """A time as UTC: a naive one is taken as UTC, an aware one is converted.

    SQLite returns stored times naive; they were stored as UTC (:func:`utcnow`).
    """
    return moment.astimezone(UTC) if moment.tzinfo else moment.replace(tzinfo=UTC)


class Base(DeclarativeBase):
    """Declarative base with the naming convention."""

    metadata = MetaData(naming_convention=NAMING_CONVENTION)
    type_annotation_map = {
        dict[str, Any]: JSON,
        list[Any]: JSON,
        datetime: DateTime(timezone=True),
    }


def core_table(entity: type[Base]) -> Table:
    """The Core table of a mapped class (for inserts without the ORM's unit of work)."""
    return cast(Table, entity.__table__)
