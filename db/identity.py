"""The database's identity: the origin its exports give its own plans' models (issue 32).

One row of ``database_identity`` (alembic 0020 makes it with a random UUID). A database made
without the migrations (``metadata.create_all``) gets its row at its first export.

A copied database (a second site set up from a copy of the first's) holds the same identity.
:func:`renew` gives it one of its own; the plans it was copied with keep the old one in
``plans.origin`` (alembic 0021), so their models travel as the first database's still, and a
third database that imports from both counts them once. A plan's origin is
:func:`plan_origins`.
"""

from __future__ import annotations

import uuid
from collections.abc import Iterable

from sqlalchemy import func, select, update
from sqlalchemy.orm import Session

from db import tables as t

#: Plan names asked for in one statement (well under SQLite's 32 766 bound parameters).
_CHUNK = 1000


def database_id(*, session: Session) -> str:
    """The UUID naming this database (made and stored in ``session`` if it has none)."""
    found = session.scalar(select(t.DatabaseIdentity.uuid).where(t.DatabaseIdentity.id == 1))
    if found is not None:
        return found
    made = str(uuid.uuid4())
    session.add(t.DatabaseIdentity(id=1, uuid=made))
    session.flush()
    return made


def renew(*, session: Session) -> tuple[str, str, int]:
    """Give this database a new identity: ``(old, new, plans that keep old)``.

    The plans created under the old identity get it in ``plans.origin`` first (one UPDATE),
    so what they learned stays the old database's.
    """
    old = database_id(session=session)
    done = session.execute(update(t.Plan).where(t.Plan.origin.is_(None)).values(origin=old))
    new = str(uuid.uuid4())
    session.execute(update(t.DatabaseIdentity).where(t.DatabaseIdentity.id == 1).values(uuid=new))
    return old, new, int(getattr(done, "rowcount", 0) or 0)


def plan_origins(*, session: Session, names: Iterable[str], own: str) -> dict[str, str]:
    """The origin of each named plan this database holds (``own``, its identity, where NULL)."""
    wanted = sorted(set(names))
    found: dict[str, str] = {}
    for start in range(0, len(wanted), _CHUNK):
        rows = session.execute(
            select(t.Plan.name, t.Plan.origin).where(
                t.Plan.name.in_(wanted[start : start + _CHUNK])
            )
        )
        found.update((name, origin or own) for name, origin in rows)
    return found


def inherited(*, session: Session) -> dict[str, int]:
    """The plans this database holds from another database's identity, counted by origin."""
    rows = session.execute(
        select(t.Plan.origin, func.count())
        .where(t.Plan.origin.is_not(None))
        .group_by(t.Plan.origin)
        .order_by(t.Plan.origin)
    )
    return {str(origin): int(count) for origin, count in rows}
