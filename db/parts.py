"""Parts: the rows of a part's record (measurements, decisions), and how many parts a plan has.

A part report is stored by :func:`db.store_report.store_report` (its measurements, decisions,
band states, model versions, setpoints and the plan's new pointers); the part's own row by
:func:`db.intake.open_report`. The caller owns the transaction.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from db import tables as t
from supervisor.constant_load.reported_tool_changes import ToolChange
from supervisor.inputs.part_report import PartReport
from supervisor.rcb.decision import Decision

#: The fields of a :class:`supervisor.rcb.update.Decision` that ``rcb_decisions`` stores
#: under their own names (its operation is stored as ``operation_id``); the table is their
#: one definition, and tests/db/test_decision_columns.py pins them to the Decision's fields.
DECISION_COLUMNS = tuple(
    c.key
    for c in t.core_table(t.RcbDecision).columns
    if c.key not in {"id", "part_id", "operation_id"}
)


def decision_rows(
    ops: Mapping[str, int], part_id: int, decisions: tuple[Decision, ...]
) -> list[dict[str, Any]]:
    """The ``rcb_decisions`` rows of a part's decisions (each under its operation's id)."""
    return [
        {
            "part_id": part_id,
            "operation_id": ops[d.operation],
            **{column: getattr(d, column) for column in DECISION_COLUMNS},
        }
        for d in decisions
    ]


def measurement_rows(
    ops: Mapping[str, int],
    part_id: int,
    report: PartReport,
    raw: Mapping[tuple[str, str], dict[str, Any]],
    tool_changes: Sequence[ToolChange],
) -> list[dict[str, Any]]:
    """The ``measurements`` rows of a part: measured quantities, tool wear, feed overrides."""
    measurements: list[dict[str, Any]] = [
        {
            "part_id": part_id,
            "operation_id": ops[name],
            "quantity": quantity,
            "value": m.value,
            "uncertainty": m.uncertainty,
            "raw": raw.get((name, quantity)),
        }
        for name, measured in report.measurements.items()
        for quantity, m in measured.items()
    ]
    measurements += [
        {
            "part_id": part_id,
            "operation_id": ops[name],
            "quantity": "flank_wear_mm",
            "value": wear.flank_wear_mm.value,
            "uncertainty": wear.flank_wear_mm.uncertainty,
            "raw": {"volume_mm3": wear.volume_mm3},
        }
        for name, wear in report.tool_wear.items()
    ]
    measurements += [
        {
            "part_id": part_id,
            "operation_id": ops[c.operation],
            "quantity": "feed_override_percent",
            "value": c.feed_override_percent,
            "uncertainty": 0.0,
            "raw": {
                "commanded_feed_rate_mm_min": c.commanded_feed_rate_mm_min,
                "feed_rate_lower_mm_min": c.feed_rate_lower_mm_min,
                "tool_change_due": c.due,
                "reason": c.reason,
            },
        }
        for c in tool_changes
    ]
    return measurements


def count_parts(*, session: Session, plan_id: int) -> int:
    """Number of parts stored for a plan."""
    return session.scalar(select(func.count()).where(t.Part.plan_id == plan_id)) or 0
