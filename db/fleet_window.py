"""Each machine's newest plans with a tool, in the database: the fleet's evidence bounded.

:mod:`supervisor.fleet.window` says why a machine speaks for a tool by its newest
:data:`~supervisor.fleet.window.PLANS_PER_MACHINE` plans. Here they are picked in the
statement that reads the evidence (a ``row_number()`` window over the plans that learned a
model of the tool, per machine and tool, newest first; SQLite and PostgreSQL alike): plans
neither halted nor taken out by an engineer (``fleet_exclusions``), so that one taken out
lets an older one in. The models themselves are read for the picked plans only, so the cost
of a new plan's fleet prior is bounded by the machines, not by the plans they made.

An imported machine (:func:`db.fleet.abroad`) speaks by its newest plans the same way, newest
by when this database imported them.
"""

from __future__ import annotations

from collections.abc import Iterable

from sqlalchemy import ColumnElement, Subquery, exists, func, or_, select

from db import tables as t
from db.fleet_states import newest_state
from supervisor.fleet.window import PLANS_PER_MACHINE

#: An engineer took the row's plan or its machine out of the fleet (``fleet_exclusions``).
excluded: ColumnElement[bool] = or_(
    t.FleetExclusion.plan_id == t.Plan.id, t.FleetExclusion.machine == t.Machine.name
)


def newest_local(tool_names: Iterable[str], n: int = PLANS_PER_MACHINE) -> Subquery:
    """``(plan_id, tool_id)`` of each machine's newest ``n`` plans with each named tool.

    Plans that learned a model of the tool since their bands were last reset, not halted,
    not taken out; a plan whose process changed counts here and is left out by the caller.
    """
    b = t.BandState
    candidates = (
        select(
            t.Plan.id.label("plan_id"),
            t.Plan.machine_id.label("machine_id"),
            t.Operation.tool_id.label("tool_id"),
        )
        .join(t.Operation, t.Operation.plan_id == t.Plan.id)
        .join(t.Tool, t.Operation.tool_id == t.Tool.id)
        .join(t.ToolModel, t.ToolModel.tool_id == t.Tool.id)
        .join(t.Machine, t.Plan.machine_id == t.Machine.id)
        .join(b, b.id == newest_state())
        .where(t.Tool.name.in_(sorted(set(tool_names))), t.Plan.halt.is_(None))
        .where(b.posterior.is_not(None), ~exists().where(excluded))
        .distinct()
        .subquery()
    )
    c = candidates.c
    rank = func.row_number().over(partition_by=(c.machine_id, c.tool_id), order_by=c.plan_id.desc())
    ranked = select(c.plan_id, c.tool_id, rank.label("rank")).subquery()
    return select(ranked.c.plan_id, ranked.c.tool_id).where(ranked.c.rank <= n).subquery()


def newest_imported(tool_names: Iterable[str], n: int = PLANS_PER_MACHINE) -> Subquery:
    """``(tool, origin, machine, plan)`` of each imported machine's newest ``n`` plans per tool.

    Newest by the last row this database imported of the plan (``imported_models.id``).
    """
    m = t.ImportedModel
    per_plan = (
        select(m.tool, m.origin, m.machine, m.plan, func.max(m.id).label("last"))
        .where(m.tool.in_(sorted(set(tool_names))))
        .group_by(m.tool, m.origin, m.machine, m.plan)
        .subquery()
    )
    c = per_plan.c
    rank = func.row_number().over(
        partition_by=(c.tool, c.origin, c.machine), order_by=c.last.desc()
    )
    ranked = select(c.tool, c.origin, c.machine, c.plan, rank.label("rank")).subquery()
    kept = ranked.c
    return select(kept.tool, kept.origin, kept.machine, kept.plan).where(kept.rank <= n).subquery()
