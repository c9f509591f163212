"""A plan as its reader sees it, and the list of plans a page at a time.

Each runs in one read transaction (on SQLite a deferred one, so it never waits for writers).
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import Engine

from api.services.read.common import LIST_PAGE, _bounded, _cursor, _plan, _read
from db import tables as t
from db.fleet import prior_answer
from db.fleet_members import plan_out
from db.parts import count_parts
from db.plans import current_body
from db.read import plans as plan_rows
from db.refused import plan_refused
from models import quantities


def get_plan(*, engine: Engine, plan_id: int, names: bool = True) -> dict[str, Any]:
    """One plan: summary, machine limits, operations (limits, bounds, volume), the plan body.

    ``names`` False: the prior's provenance without the fleet's plans' and machines' names
    (a key scoped to plans, :func:`db.fleet.prior_answer`).
    """
    with _read(engine) as session, session.begin():
        row = _plan(session, plan_id)
        machine = session.get(t.Machine, row.machine_id)
        ops = plan_rows.operations(session=session, plan_id=plan_id)
        parts = count_parts(session=session, plan_id=plan_id)
        body = current_body(session=session, plan_row=row)
        in_force = {o.get("name"): o for o in body.get("operations", [])}
        return {
            **plan_rows.summary(row, machine.name if machine else "", parts),
            "machine_limits": {
                key: machine.limits.get(name) if machine else None
                for key, name in quantities.machine_fields().items()
            },
            **prior_answer(row.prior, row.noise_prior, names),
            "operations": [
                {
                    "name": op.name,
                    "tool": tool.name,
                    "process": op.process,
                    "volume_mm3": op.volume_mm3,
                    # as in force: a replan may have changed them (plan_revisions)
                    "limits": dict(in_force.get(op.name, {}).get("limits", op.limits)),
                    "bounds": dict(in_force.get(op.name, {}).get("bounds", op.bounds)),
                    "context": dict(op.context),
                }
                for op, tool in ops
            ],
            "body": body,
            "plan_refused": plan_refused(session=session, plan_row=row),
            "fleet_out": plan_out(
                session=session, row=row, machine=machine.name if machine else ""
            ),
        }


def list_plans(
    *,
    engine: Engine,
    cursor: str | None = None,
    page_size: int = LIST_PAGE,
    only: frozenset[int] | None = None,
) -> dict[str, Any]:
    """A page of plans by id: machine, current setpoint version and part count.

    ``page_size``: the REST ``limit`` (1 to :data:`api.services.read.common.MAX_PAGE`);
    ``cursor``: the ``next_cursor`` of the previous page (null on the last). ``only``: just
    these plan ids (a key scoped to plans), filtered in the query, so its page is full and
    names no other plan.
    """
    _bounded(page_size)
    after = _cursor(cursor)
    with _read(engine) as session, session.begin():
        rows = plan_rows.plans(session=session, after_id=after, limit=page_size + 1, only=only)
    more = len(rows) > page_size
    rows = rows[:page_size]
    return {"plans": rows, "next_cursor": str(rows[-1]["id"]) if more else None}
