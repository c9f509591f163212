"""Band states no reader needs any more, deleted a batch at a time: ``rcb db prune``.

A part's report appends one ``band_states`` row per band it moved (2.4 kB each on the
demonstration plan, whose ``learn`` beliefs keep their readings' information: 29 kB a part
over 12 bands, 80 % of what the database grows by; measured 2026-12-06). Only the newest row
of each band is in force (:func:`db.state.load_state`, :func:`db.fleet_states.newest_state`),
and, while a change of the plan's process waits to be judged, the newest before the part it
opened at (``plans.fleet_change_part``, :mod:`db.fleet_changes`); no surface reads an older
one (``rcb history`` and the report read the decisions and model versions, which are kept).

A row is deleted where its part was received before the cut-off and a newer row of its band
exists that keeps whatever it was kept for: any newer row, unless the row is the newest before
its plan's pending change, which only a newer row also before that part replaces. The newest
row of every band is never deleted, whatever its age, so the state a plan would load, and the
fleet's evidence, are the same before and after.
"""

from __future__ import annotations

from datetime import datetime

from sqlalchemy import and_, delete, exists, or_, select
from sqlalchemy.orm import Session

from db import tables as t

_STATES = t.core_table(t.BandState)
_NEWER = _STATES.alias("newer")


def prunable_states(*, session: Session, before: datetime, limit: int) -> list[int]:
    """Ids of at most ``limit`` band states no reader needs (module docstring), oldest first.

    Of parts received before ``before``.
    """
    b, n = _STATES.c, _NEWER.c
    cut = t.Plan.fleet_change_part  # the part a pending change opened at, else NULL
    replaced = exists().where(
        n.operation_id == b.operation_id,
        n.quantity == b.quantity,
        n.part_id > b.part_id,
        or_(cut.is_(None), b.part_id >= cut, n.part_id < cut),
    )
    query = (
        select(b.id)
        .join(t.Part, t.Part.id == b.part_id)
        .join(t.Plan, t.Plan.id == t.Part.plan_id)
        .where(and_(t.Part.received_at < before, replaced))
        .order_by(b.id)
        .limit(limit)
    )
    return list(session.scalars(query))


def delete_states(*, session: Session, ids: list[int]) -> int:
    """Delete the band states ``ids``; how many were deleted."""
    if not ids:
        return 0
    done = session.execute(delete(_STATES).where(_STATES.c.id.in_(ids)))
    return int(getattr(done, "rowcount", 0) or 0)
