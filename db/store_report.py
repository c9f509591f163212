"""One accepted part report stored: the one place a part's new versions are written.

:func:`store_report` writes, in the caller's transaction, everything a part adds after its row
(:func:`db.intake.open_report` inserts that, in the statement that locks the plan): its
measurements and decisions (:mod:`db.parts`), the band states its decisions touched, the model
versions it changed, the setpoint version it made (:func:`db.plans.add_setpoints`), the
plan's new pointers (setpoint version, state token, halt) and, if it halted the plan, an audit
entry of the halt (actor ``rcb``, action ``halt``).

Only the setpoints are inserted at once (their version's id is needed for their rows); the other
rows and the plan's pointers are deferred (:func:`db.bulk.defer`) so that, on PostgreSQL, they go
out in one statement with the idempotency record and the audit entry
(:func:`db.bulk.write_deferred`), or at the latest when the transaction commits.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from sqlalchemy.orm import Session

from db import tables as t
from db.audit import audit_row
from db.bulk import defer
from db.fleet import let_go
from db.fleet_changes import fleet_change
from db.fleet_noise import noise_let_go
from db.intake import PlanHead
from db.model_versions import model_version_row, version_numbers
from db.parts import decision_rows, measurement_rows
from db.plan_state import halt_json
from db.plans import add_setpoints, new_token
from supervisor.constant_load.reported_tool_changes import ToolChange
from supervisor.inputs.part_report import PartReport
from supervisor.rcb.decision import Decision
from supervisor.rcb.monitor_state import Monitor
from supervisor.rcb.posterior import Posterior
from supervisor.rcb.state import RcbState
from supervisor.rcb.wear import WearRise


def store_report(
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
) -> str:
    """Store a part's record and the state it leaves; return the plan's new state token.

    ``part_id``: the part's row, stored by :func:`db.intake.open_report` in the same transaction;
    ``operations``: the plan's operation ids (:func:`db.plans.operation_ids`). ``raw``: per
    (operation, quantity) what a measurement was converted from (a spindle reading,
    :mod:`supervisor.inputs.signals`), kept beside the converted value. ``tool_changes``: each
    reported feed override, stored as a ``feed_override_percent`` measurement. ``plan_row`` is
    updated to the new pointers, as the deferred update stores them.
    """
    ops = operations
    rows = [
        (t.Measurement, measurement_rows(ops, part_id, report, raw or {}, tool_changes)),
        (t.RcbDecision, decision_rows(ops, part_id, decisions)),
        (t.BandState, band_state_rows(ops, part_id, decisions, after)),
        (
            t.OperationModelVersion,
            _model_version_rows(session, plan_row.id, ops, part_id, before, after),
        ),
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
    pointers = _pointers(plan_row, before, after)
    if "halt" in pointers:  # in the audit log too: rcb audit --action halt, the plant's halts
        rows.append((t.AuditEntry, [_halt_entry(plan_row.id, report.serial, after)]))
    pointers.update(
        fleet_change(session=session, plan=plan_row, part_id=part_id, before=before, after=after)
    )
    pointers.update(_let_go(plan_row, before, after, report.serial))
    # Core rows, no ORM bookkeeping; deferred, so they go out with the transaction's last rows
    defer(
        session,
        [(t.core_table(table), table_rows) for table, table_rows in rows],
        updates=[(t.core_table(t.Plan), [pointers])],
    )
    plan_row.current_setpoint_version = after.version
    plan_row.state_token = pointers["state_token"]
    if "halt" in pointers:
        plan_row.halt = pointers["halt"]
    return plan_row.state_token


def _halt_entry(plan_id: int, serial: str, after: RcbState) -> dict[str, Any]:
    """The audit entry of the part that halted the plan: which part, which operations, why."""
    halt = after.halt
    assert halt is not None
    detail = {
        "part": serial,
        "operations": [o.operation for o in halt.operations],
        "message": halt.message,
    }
    result = "halted until a replan"
    return audit_row("rcb", "halt", f"plan {plan_id}", result, detail, plan_id)


def _let_go(plan_row: PlanHead, before: RcbState, after: RcbState, serial: str) -> dict[str, Any]:
    """The fleet priors the part's readings let go, marked: every surface says which part did.

    ``plans.prior`` and ``plans.noise_prior`` (:mod:`db.fleet`, :mod:`db.fleet_noise`).
    """
    out: dict[str, Any] = {}
    prior = let_go(plan_row.prior, before.posterior, after.posterior, serial)
    if prior is not None:
        out["prior"] = plan_row.prior = prior
    noise = noise_let_go(plan_row.noise_prior, before.noise_priors, after.noise_priors, serial)
    if noise is not None:
        out["noise_prior"] = plan_row.noise_prior = noise
    return out


def band_state_rows(
    operations: Mapping[str, int], part_id: int, decisions: tuple[Decision, ...], after: RcbState
) -> list[dict[str, Any]]:
    """The ``band_states`` rows of the bands a part's ``decisions`` touched, as in ``after``."""
    return [
        {
            "operation_id": operations[d.operation],
            "quantity": d.quantity,
            "part_id": part_id,
            "seen": after.seen[(d.operation, d.quantity)],
            "sigma": after.sigma[(d.operation, d.quantity)],
            "posterior": _json_or_none(after.posterior.get((d.operation, d.quantity))),
            "wear": _json_or_none(after.wear.get((d.operation, d.quantity))),
            "monitor": _json_or_none(after.monitors.get((d.operation, d.quantity))),
        }
        for d in decisions
    ]


def _json_or_none(belief: Posterior | WearRise | Monitor | None) -> dict[str, Any] | None:
    """A belief as the JSON of its ``band_states`` column (None: no belief)."""
    return None if belief is None else belief.to_json()


def _model_version_rows(
    session: Session,
    plan_id: int,
    ops: Mapping[str, int],
    part_id: int,
    before: RcbState,
    after: RcbState,
) -> list[dict[str, Any]]:
    """The ``operation_model_versions`` rows of the models the part changed (cause ``part``).

    Each is the next version of its (operation, quantity); the numbers are read only when a
    model changed.
    """
    changed = [
        (name, model)
        for name, tool in after.tools.items()
        for model in tool.models.values()
        if before.tools[name].models[model.quantity] != model
    ]
    versions = version_numbers(session=session, plan_id=plan_id) if changed else {}
    return [
        model_version_row(
            ops[name], model, versions[(ops[name], model.quantity)] + 1, "part", part_id
        )
        for name, model in changed
    ]


def _pointers(plan_row: PlanHead, before: RcbState, after: RcbState) -> dict[str, Any]:
    """The plan row's update: setpoint version in force, a new state token, a new halt.

    The halt is set only when the part halted the plan (it stays until a replan).
    """
    pointers: dict[str, Any] = {
        "id": plan_row.id,
        "current_setpoint_version": after.version,
        "state_token": new_token(),
    }
    if after.halt is not None and before.halt is None:
        pointers["halt"] = halt_json(after.halt)
    return pointers
