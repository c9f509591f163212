"""Parts: what a part report stores, and how many parts a plan has.

A report stores measurements, decisions, model and band changes, new setpoints and the
plan's new pointers. The part's own row is stored by :func:`db.intake.open_report`; the
caller owns the transaction.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from db import tables as t
from db.bulk import defer
from db.intake import PlanHead
from db.model_versions import model_version_row, version_numbers
from db.plan_state import halt_json
from db.plans import add_setpoints, new_token
from db.state import band_state_rows
from supervisor.constant_load.reported_tool_changes import ToolChange
from supervisor.inputs.part_report import PartReport
from supervisor.rcb.decision import Decision
from supervisor.rcb.state import RcbState

#: The fields of a :class:`supervisor.rcb.update.Decision` that ``rcb_decisions`` stores
#: under their own names (its operation is stored as ``operation_id``); the table is their
#: one definition, and tests/db/test_decision_columns.py pins them to the Decision's fields.
DECISION_COLUMNS = tuple(
    c.key
    for c in t.core_table(t.RcbDecision).columns
    if c.key not in {"id", "part_id", "operation_id"}
)


def add_part(
    *,
    session: Session,
    plan_row: PlanHead,
    part_id: int,
    operations: Mapping[str, int],
    report: PartReport,
    decisions: tuple[Decision, ...],
    before: RcbState,
    after: RcbState,
    raw: Mapping[tuple[str, str], dict[str, Any]] | None = None,
    tool_changes: Sequence[ToolChange] = (),
) -> None:
    """Store a part's measurements and decisions, changed models, band states, setpoints.

    The setpoints are inserted now; the other rows and the plan's new pointers are deferred
    (:func:`db.bulk.defer`): they are written by :func:`db.bulk.write_deferred`, or at the
    latest when the transaction commits.

    ``part_id``: the part's row, stored by :func:`db.intake.open_report` in the same transaction;
    ``operations``: the plan's operation ids (:func:`db.plans.operation_ids`). ``raw``: per
    (operation, quantity) what a measurement was converted from (a spindle reading,
    :mod:`supervisor.inputs.signals`), kept beside the converted value. ``tool_changes``: each
    reported feed override, stored as a ``feed_override_percent`` measurement with the
    commanded feed, the lower limit and whether a tool change was due.
    """
    ops = operations
    measurements = _measurement_rows(ops, part_id, report, raw or {}, tool_changes)
    decision_rows = [
        {
            "part_id": part_id,
            "operation_id": ops[d.operation],
            **{column: getattr(d, column) for column in DECISION_COLUMNS},
        }
        for d in decisions
    ]
    band_states = band_state_rows(operations=ops, part_id=part_id, decisions=decisions, after=after)
    changed = [
        (name, model)
        for name, tool in after.tools.items()
        for model in tool.models.values()
        if before.tools[name].models[model.quantity] != model
    ]
    versions = version_numbers(session=session, plan_id=plan_row.id) if changed else {}
    model_rows = [
        model_version_row(
            ops[name], model, versions[(ops[name], model.quantity)] + 1, "part", part_id
        )
        for name, model in changed
    ]
    if after.version != before.version:
        add_setpoints(
            session=session,
            plan_id=plan_row.id,
            operations=ops,
            result=after.setpoints,
            version=after.version,
            cause="part",
            part_id=part_id,
        )
    token = new_token()
    pointers: dict[str, Any] = {
        "id": plan_row.id,
        "current_setpoint_version": after.version,
        "state_token": token,
    }
    halt = None
    if after.halt is not None and before.halt is None:  # halted now: until a replan
        halt = pointers["halt"] = halt_json(after.halt)
    # Core rows, no ORM bookkeeping; deferred, so they go out with the transaction's last rows
    defer(
        session,
        [
            (t.core_table(t.Measurement), measurements),
            (t.core_table(t.RcbDecision), decision_rows),
            (t.core_table(t.BandState), band_states),
            (t.core_table(t.OperationModelVersion), model_rows),
        ],
        updates=[(t.core_table(t.Plan), [pointers])],
    )
    plan_row.current_setpoint_version = after.version
    plan_row.state_token = token
    if halt is not None:
        plan_row.halt = halt


def _measurement_rows(
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
