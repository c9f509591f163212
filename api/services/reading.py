"""What the read use cases share: a read session, page bounds, cursors, UTC times, a plan."""

from __future__ import annotations

import re
from datetime import UTC, datetime

from sqlalchemy import Engine
from sqlalchemy.orm import Session

from api.services import sizes
from api.services.errors import NotFoundError
from db import tables as t
from db.engine import reader
from db.plans import get_plan_row
from models.errors import InputError

#: Most parts (or setpoint versions) one page may hold.
MAX_PAGE = sizes.READ_PAGE


def _read(engine: Engine) -> Session:
    # rows are read after the transaction ends: keep their loaded attributes
    return Session(reader(engine), expire_on_commit=False)


def _utc(moment: datetime) -> datetime:
    # SQLite returns naive datetimes; they were stored as UTC (db.tables.utcnow)
    return moment if moment.tzinfo else moment.replace(tzinfo=UTC)


def _cursor(cursor: str | None) -> int:
    if cursor is None:
        return 0
    if re.fullmatch(r"[0-9]{1,10}", cursor) is None or int(cursor) > t.MAX_INT:
        raise InputError("cursor", cursor, "not a cursor returned by this endpoint")
    return int(cursor)


def _plan(session: Session, plan_id: int) -> t.Plan:
    row = get_plan_row(session=session, plan_id=plan_id)
    if row is None:
        raise NotFoundError("plan_id", plan_id)
    return row
