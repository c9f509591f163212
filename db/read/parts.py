"""A plan's parts a page at a time, with their measurements and RCB decisions.

Each returns rows; :mod:`api.services.read.plan_parts` shapes them for JSON.
"""

from __future__ import annotations

from collections import defaultdict
from datetime import datetime

from sqlalchemy import func, select
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
    still returned oldest first (more: older ones). ``since``: the parts from the first one
    received at or after this time on (:func:`first_since`).
    """
    query = select(t.Part).where(t.Part.plan_id == plan_id)
    floor = 0  # the ids above it: one bound, so the seek starts there whichever is higher
    if since is not None:
        first = first_since(session=session, plan_id=plan_id, since=since)
        if first is None:
            return [], {}, {}, False
        floor = first - 1
    if newest:
        if floor:
            query = query.where(t.Part.id > floor)
        if after_id:
            query = query.where(t.Part.id < after_id)
        parts = list(session.scalars(query.order_by(t.Part.id.desc()).limit(limit + 1)))
        more, parts = len(parts) > limit, parts[:limit][::-1]
    else:
        query = query.where(t.Part.id > max(after_id, floor))
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


#: How many of the first parts stamped at or after ``since`` :func:`first_since` reads: more
#: than can race for a plan's lock at once (a report is stamped before it waits for the lock).
RACING = 64


def first_since(*, session: Session, plan_id: int, since: datetime) -> int | None:
    """The smallest id of the plan's parts received at or after ``since``; None if none was.

    Read from the first :data:`RACING` of them by time, one seek of ``ix_parts_plan_received``;
    a page then seeks ``ix_parts_plan_id`` from this id, so a page ``since`` costs the same
    after a year of parts as after a day (filtering ``received_at`` in the page's own query
    read every part before ``since`` on an ``order=oldest`` page, and every part of the plan
    on the last ``order=newest`` one). Parts are listed in the order they were stored (their
    id): one stored after this one but stamped a moment before ``since`` (reports of the plan
    that raced for its lock) is listed with the rest, as the plan learned from it then.
    """
    stamped = (
        select(t.Part.id)
        .where(t.Part.plan_id == plan_id, t.Part.received_at >= as_utc(since))
        .order_by(t.Part.received_at)
        .limit(RACING)
        .subquery()
    )
    first: int | None = session.scalar(select(func.min(stamped.c.id)))
    return first
