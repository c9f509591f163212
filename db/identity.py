"""The database's identity: the origin its exports give its own plans' models (issue 32).

One row of ``database_identity`` (alembic 0020 makes it with a random UUID). A database made
without the migrations (``metadata.create_all``) gets its row at its first export.
"""

from __future__ import annotations

import uuid

from sqlalchemy import select
from sqlalchemy.orm import Session

from db import tables as t


def database_id(*, session: Session) -> str:
    """The UUID naming this database (made and stored in ``session`` if it has none)."""
    found = session.scalar(select(t.DatabaseIdentity.uuid).where(t.DatabaseIdentity.id == 1))
    if found is not None:
        return found
    made = str(uuid.uuid4())
    session.add(t.DatabaseIdentity(id=1, uuid=made))
    session.flush()
    return made
