"""What a plan's report reads beyond one page of parts: totals and summaries as SQL aggregates.

Every function returns a number of rows bounded by what the report shows (a few, or one per
operation and quantity, or one per group of setpoint versions), never by the plan's history;
the database does the counting.
"""

from __future__ import annotations

from collections import defaultdict
from datetime import datetime

from sqlalchemy import case, func, or_, select
from sqlalchemy.orm import Session

from db import tables as t


def part_totals(*, session: Session, plan_id: int) -> tuple[int, datetime | None]:
    """How many parts the plan has and when the last was received."""
    p = t.Part
    count, last = session.execute(
        select(func.count(p.id), func.max(p.received_at)).where(p.plan_id == plan_id)
    ).one()
    return int(count), last


def decision_totals(*, session: Session, plan_id: int) -> dict[str, int]:
    """Flagged RCB decisions, those past a limit (breaches), notes, and readings to check.

    ``checks``: the decisions with the note ``implausible_low`` (a reading quarantined as too
    good to be true: the operator checks the sensor and the tool); they count as notes too.
    """
    d = t.RcbDecision
    operations = select(t.Operation.id).where(t.Operation.plan_id == plan_id)
    flagged, breaches, notes, checks = session.execute(
        select(
            func.sum(case((d.flagged, 1), else_=0)),
            func.sum(case((d.flag == "breach", 1), else_=0)),
            func.sum(case((d.note.is_not(None), 1), else_=0)),
            func.sum(case((d.note == "implausible_low", 1), else_=0)),
        )
        # the marked decisions alone (ix_rcb_decisions_marked): a flag is set only when
        # flagged, so the others count 0 in every sum
        .where(d.operation_id.in_(operations), or_(d.flagged, d.note.is_not(None)))
    ).one()
    return {
        "flagged": int(flagged or 0),
        "breaches": int(breaches or 0),
        "notes": int(notes or 0),
        "checks": int(checks or 0),
    }


def version_groups(
    *, session: Session, plan_id: int, up_to: int, size: int
) -> list[tuple[int, int, int]]:
    """Setpoint versions 1 … ``up_to`` in groups of ``size``: (first, last, count) per group."""
    v = t.SetpointVersion
    group = (v.version - 1) // size
    rows = session.execute(
        select(func.min(v.version), func.max(v.version), func.count(v.id))
        .where(v.plan_id == plan_id, v.version <= up_to)
        .group_by(group)
        .order_by(func.min(v.version))
    ).all()
    return [(int(a), int(b), int(n)) for a, b, n in rows]


def versions(
    *, session: Session, plan_id: int, newer_than: int, numbers: set[int]
) -> list[tuple[t.SetpointVersion, str | None, list[t.Setpoint]]]:
    """The versions numbered above ``newer_than`` or in ``numbers``, oldest first.

    Each with the serial of the part that caused it and its setpoints (two statements).
    """
    v = t.SetpointVersion
    rows = session.execute(
        select(v, t.Part.serial)
        .outerjoin(t.Part, v.part_id == t.Part.id)
        .where(v.plan_id == plan_id, or_(v.version > newer_than, v.version.in_(sorted(numbers))))
        .order_by(v.version)
    ).all()
    setpoints: dict[int, list[t.Setpoint]] = defaultdict(list)
    ids = [row.id for row, _ in rows]
    if ids:
        for sp in session.scalars(
            select(t.Setpoint).where(t.Setpoint.setpoint_version_id.in_(ids))
        ):
            setpoints[sp.setpoint_version_id].append(sp)
    return [(row, serial, setpoints[row.id]) for row, serial in rows]


def last_decisions(*, session: Session, plan_id: int) -> list[tuple[t.RcbDecision, str]]:
    """Per operation and quantity the newest RCB decision of the plan, with its part's serial."""
    d, p, o = t.RcbDecision, t.Part, t.Operation
    # per operation and its tool's quantity, the end of ix_rcb_decisions_operation_quantity_part
    newest_part = (
        select(func.max(d.part_id))
        .where(d.operation_id == o.id, d.quantity == t.ToolModel.quantity)
        .scalar_subquery()
    )
    newest = (
        select(o.id.label("operation_id"), t.ToolModel.quantity, newest_part.label("part_id"))
        .join(t.ToolModel, t.ToolModel.tool_id == o.tool_id)
        .where(o.plan_id == plan_id)
        .distinct()  # read first, each row once (SQLite would flatten it into a walk)
        .subquery()
    )
    rows = session.execute(
        select(d, p.serial)
        .join(p, p.id == d.part_id)
        .join(
            newest,
            (newest.c.operation_id == d.operation_id)
            & (newest.c.quantity == d.quantity)
            & (newest.c.part_id == d.part_id),
        )
        .order_by(d.id)
    ).all()
    return [(decision, serial) for decision, serial in rows]


def marked_decisions(*, session: Session, part_ids: list[int]) -> dict[int, list[t.RcbDecision]]:
    """The flagged or noted RCB decisions of these parts, per part, in the order made."""
    d = t.RcbDecision
    out: dict[int, list[t.RcbDecision]] = defaultdict(list)
    if part_ids:
        for row in session.scalars(
            select(d)
            .where(d.part_id.in_(part_ids), or_(d.flagged, d.note.is_not(None)))
            .order_by(d.id)
        ):
            out[row.part_id].append(row)
    return out


def summary_of(groups: list[tuple[int, int, int]]) -> set[int]:
    """The version numbers a summary row shows (the first and last of each group)."""
    return {n for first, last, _ in groups for n in (first, last)}
