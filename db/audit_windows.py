"""Authentication failures counted per audit window over every instance on the database.

One row of ``auth_failure_windows`` per client address, action, reason and window; each
process adds the failures it counted since it last wrote (:func:`add`), and the window's
audit entry (``result`` unauthenticated) is written with the sum in ``detail.count``. The
upsert that adds holds the window's row until commit, so two instances adding at once are
serialised: one audit entry per window, its count never rewritten smaller. An entry pruned
meanwhile (``rcb db prune``) is appended again with the window's whole count.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import delete, text, update
from sqlalchemy.orm import Session

from db import audit
from db import tables as t

_ADD = """
INSERT INTO auth_failure_windows (client, action, reason, window_start_s, count)
VALUES (:client, :action, :reason, :start, :delta)
ON CONFLICT (client, action, reason, window_start_s)
DO UPDATE SET count = auth_failure_windows.count + :delta
RETURNING count, audit_id
"""


def add(
    *,
    session: Session,
    client: str,
    action: str,
    reason: str,
    start_s: float,
    window_s: float,
    delta: int,
) -> int:
    """Add ``delta`` failures to the window starting at ``start_s``; returns its count.

    Writes the window's audit entry (a new one on the first failure, or when it was pruned).
    """
    values = {"client": client, "action": action, "reason": reason, "start": start_s}
    count, audit_id = session.execute(text(_ADD), {**values, "delta": delta}).one()
    detail: dict[str, Any] = {
        "reason": reason,
        "client": client,
        "count": int(count),
        "window_start_s": start_s,
        "window_s": window_s,
    }
    if audit_id is None or not audit.set_audit_detail(
        session=session, entry_id=audit_id, detail=detail
    ):
        row = audit.audit_row("anonymous", action, "", "unauthenticated", detail)
        audit_id = audit.audit_returning_id(session=session, row=row)
        window = t.core_table(t.AuthFailureWindow)
        this = (
            (window.c.client == client)
            & (window.c.action == action)
            & (window.c.reason == reason)
            & (window.c.window_start_s == start_s)
        )
        session.execute(update(window).where(this).values(audit_id=audit_id))
    return int(count)


def prune(*, session: Session, before_s: float) -> int:
    """Delete the windows that started before ``before_s`` (their entries stay); how many."""
    window = t.core_table(t.AuthFailureWindow)
    done = session.execute(delete(window).where(window.c.window_start_s < before_s))
    return int(getattr(done, "rowcount", 0) or 0)
