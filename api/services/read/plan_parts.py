"""A plan's parts as reported: their measurements per operation and the RCB decisions made.

Each runs in one read transaction (on SQLite a deferred one, so it never waits for writers);
a page reads only its own rows.

A page's cursor says which way it pages (:func:`api.services.read.common.ordered_cursor`): a
part's id (``"41"``) pages forward from the oldest, ``"n41"`` back from the newest.
"""

from __future__ import annotations

from collections.abc import Iterator
from datetime import datetime
from typing import Any

from sqlalchemy import Engine

from api.services.errors import NotFoundError
from api.services.read.common import MAX_PAGE, _bounded, _plan, _read, ordered_cursor, ordered_value
from db import tables as t
from db.read.parts import decisions_of, parts_page
from db.read.plans import operations
from db.table_base import as_utc


def parts(
    *,
    engine: Engine,
    plan_id: int,
    cursor: str | None = None,
    page_size: int = 50,
    newest: bool = False,
    since: datetime | None = None,
) -> dict[str, Any]:
    """A page of a plan's parts, oldest first; ``next_cursor`` continues after the last.

    ``page_size``: most parts on the page (the REST query parameter ``limit``). ``newest``:
    the newest parts before ``cursor`` (``next_cursor`` then pages back in time, and says so:
    module docstring). ``since``: the parts from the first one received at or after this time
    on (:func:`db.read.parts.first_since`). Only the page's rows are read, by an index seek
    either way (:func:`db.read.parts.parts_page`).
    """
    _bounded(page_size)
    after = ordered_value(cursor, newest=newest)
    with _read(engine) as session, session.begin():
        _plan(session, plan_id)
        names = {op.id: op.name for op, _ in operations(session=session, plan_id=plan_id)}
        rows, measurements, decisions, more = parts_page(
            session=session,
            plan_id=plan_id,
            after_id=after,
            limit=page_size,
            newest=newest,
            since=since,
        )
        items = [part_json(part, measurements[part.id], decisions[part.id], names) for part in rows]
    edge = (rows[0] if newest else rows[-1]) if rows and more else None
    following = None if edge is None else ordered_cursor(edge.id, newest=newest)
    return {"items": items, "next_cursor": following}


def part(*, engine: Engine, plan_id: int, part_id: int) -> dict[str, Any]:
    """One part of a plan as :func:`parts` lists it (``GET /plans/{id}/parts/{part_id}``).

    The page of one part from ``part_id`` on (one seek); a part of another plan is not found,
    as one that does not exist.
    """
    with _read(engine) as session, session.begin():
        _plan(session, plan_id)
        rows, measurements, decisions, _ = parts_page(
            session=session, plan_id=plan_id, after_id=part_id - 1, limit=1
        )
        if not rows or rows[0].id != part_id:
            raise NotFoundError("part_id", part_id)
        names = {op.id: op.name for op, _ in operations(session=session, plan_id=plan_id)}
        return part_json(rows[0], measurements[part_id], decisions[part_id], names)


def decisions(*, engine: Engine, plan_id: int, part_ids: list[int]) -> dict[int, list[Any]]:
    """The RCB decisions of these parts of a plan (``updates`` of :func:`parts`), per part id."""
    with _read(engine) as session, session.begin():
        names = {op.id: op.name for op, _ in operations(session=session, plan_id=plan_id)}
        found = decisions_of(session=session, part_ids=part_ids)
    return {part: [decision_json(d, names) for d in rows] for part, rows in found.items()}


def all_parts(*, engine: Engine, plan_id: int) -> list[dict[str, Any]]:
    """Every part of a plan, oldest first (:func:`parts`, page after page)."""
    return [item for page in part_pages(engine=engine, plan_id=plan_id) for item in page]


def part_pages(
    *, engine: Engine, plan_id: int, since: datetime | None = None
) -> Iterator[list[dict[str, Any]]]:
    """A plan's parts page by page, oldest first: one page in memory at a time."""
    cursor = None
    while True:
        page = parts(engine=engine, plan_id=plan_id, cursor=cursor, page_size=MAX_PAGE, since=since)
        if page["items"]:
            yield page["items"]
        cursor = page["next_cursor"]
        if cursor is None:
            return


def part_json(
    part: t.Part,
    measurements: list[t.Measurement],
    decisions: list[t.RcbDecision],
    names: dict[int, str],
) -> dict[str, Any]:
    """A part as an item of :func:`parts`: its measurements per operation and its decisions."""
    per_op: dict[str, dict[str, Any]] = {}
    for m in measurements:
        entry = per_op.setdefault(names[m.operation_id], {"measurements": {}})
        if m.quantity == "flank_wear_mm":
            entry["tool_wear"] = {
                "flank_wear_mm": {"value": m.value, "uncertainty": m.uncertainty},
                "volume_mm3": (m.raw or {}).get("volume_mm3"),
            }
        else:
            entry["measurements"][m.quantity] = {
                "value": m.value,
                "uncertainty": m.uncertainty,
                **({"raw": m.raw} if m.raw else {}),
            }
    return {
        "part_id": part.id,
        "serial": part.serial,
        "setpoint_version": part.setpoint_version,
        "received_at": as_utc(part.received_at),
        "operations": [{"name": name, **entry} for name, entry in per_op.items()],
        "updates": [decision_json(d, names) for d in decisions],
    }


def decision_json(d: t.RcbDecision, names: dict[int, str]) -> dict[str, Any]:
    """An RCB decision as in a part's ``updates``, its operation by name."""
    return {
        "operation": names[d.operation_id],
        "quantity": d.quantity,
        "action": d.action,
        "margin": d.margin,
        "band_before": d.band_before,
        "band_after": d.band_after,
        "predicted": d.predicted,  # None for a decision stored before alembic 0029
        "measured": d.measured,
        "flagged": d.flagged,
        "flag": d.flag,
        "note": d.note,
        "reason": d.reason,
    }
