"""A plan's parts a page at a time, with their measurements and RCB decisions.

Each returns rows; :mod:`api.services.read.plan_parts` shapes them for JSON.
"""

from __future__ import annotations

from collections import defaultdict
from datetime import datetime

from sqlalchemy import select
from sqlalchemy.orm import Session

from db import tables as t
from db.table_base import as_utc


def parts_page(
    *,
    session: Session,
    plan_id: int,
    after_id: int,
    limit: int,
    newest: bool = False,
    since: datetime | None = None,
) -> tuple[list[t.Part], dict[int, list[t.Measurement]], dict[int, list[t.RcbDecision]], bool]:
    """Up to ``limit`` parts with id > ``after_id``, oldest first, and whether more follow.

    With each part its measurements and decisions; one row more is read to tell what follows.

    ``newest``: the newest ``limit`` parts with id < ``after_id`` (0: the newest of all),
    still returned oldest first (more: older ones). ``since``: only parts received at or
    after this time.
    """
    query = select(t.Part).where(t.Part.plan_id == plan_id)
    if since is not None:
        query = query.where(t.Part.received_at >= as_utc(since))
    if newest:
        if after_id:
            query = query.where(t.Part.id < after_id)
        parts = list(session.scalars(query.order_by(t.Part.id.desc()).limit(limit + 1)))
        more, parts = len(parts) > limit, parts[:limit][::-1]
    else:
        query = query.where(t.Part.id > after_id)
        parts = list(session.scalars(query.order_by(t.Part.id).limit(limit + 1)))
        more, parts = len(parts) > limit, parts[:limit]
    ids = [p.id for p in parts]
    measurements: dict[int, list[t.Measurement]] = defaultdict(list)
    if ids:
        for m in session.scalars(
            select(t.Measurement).where(t.Measurement.part_id.in_(ids)).order_by(t.Measurement.id)
        ):
            measurements[m.part_id].append(m)
    return parts, measurements, decisions_of(session=session, part_ids=ids), more


def decisions_of(*, session: Session, part_ids: list[int]) -> dict[int, list[t.RcbDecision]]:
    """The RCB decisions of these parts, per part in the order made (an index seek each)."""
    decisions: dict[int, list[t.RcbDecision]] = defaultdict(list)
    if part_ids:
        for d in session.scalars(
            select(t.RcbDecision)
            .where(t.RcbDecision.part_id.in_(part_ids))
            .order_by(t.RcbDecision.id)
        ):
            decisions[d.part_id].append(d)
    return decisions
