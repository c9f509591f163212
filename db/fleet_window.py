"""Each machine's newest plans with a tool, in the database: the fleet's evidence bounded.

:mod:`supervisor.fleet.window` says why a machine speaks for a tool by its newest
:data:`~supervisor.fleet.window.PLANS_PER_MACHINE` plans. Here they are picked in the
statement that reads the evidence (per machine and tool, its plans that learned a model of
the tool, newest first, up to the limit): plans neither halted nor taken out by an engineer
(``fleet_exclusions``), so that one taken out lets an older one in. Each machine's walk
stops at its limit on an index (:func:`newest_local`), and the models are read for the
picked plans only, so the cost of a new plan's fleet prior is bounded by the machines, not
by the plans they made.

An imported machine (:func:`db.fleet.abroad`) speaks by its newest plans the same way, newest
by when this database imported them.
"""

from __future__ import annotations

from collections.abc import Iterable

from sqlalchemy import ColumnElement, Exists, Subquery, and_, exists, func, or_, select, true
from sqlalchemy.orm import aliased

from db import tables as t
from db.fleet_states import newest_state
from supervisor.fleet.window import PLANS_PER_MACHINE

#: An engineer took the row's plan or its machine out of the fleet (``fleet_exclusions``).
excluded: ColumnElement[bool] = or_(
    t.FleetExclusion.plan_id == t.Plan.id, t.FleetExclusion.machine == t.Machine.name
)


def newest_local(tool_names: Iterable[str], dialect: str, n: int = PLANS_PER_MACHINE) -> Subquery:
    """``(operation_id, plan_id, tool_id)`` of each machine's newest ``n`` plans with each tool.

    Plans that learned a model of the tool since their bands were last reset, not halted,
    not taken out; a plan whose process changed counts here and is left out by the caller.
    Each machine and tool is walked newest first on ``ix_operations_tool_machine_plan`` and
    the walk stops at the ``n``-th plan (a correlated ``LIMIT``: ``LATERAL`` on PostgreSQL,
    ``IN`` on SQLite, ``dialect``), so the rows read are bounded by the machines, not by the
    plans they made.
    """
    machine, tool = aliased(t.Machine, name="window_machine"), aliased(t.Tool, name="window_tool")
    o = t.Operation
    walk = (
        select(o.plan_id.label("plan_id"))
        .join(t.Plan, t.Plan.id == o.plan_id)
        .join(t.Machine, t.Machine.id == o.machine_id)
        .where(o.tool_id == tool.id, o.machine_id == machine.id, t.Plan.halt.is_(None))
        .where(_learned(), ~exists().where(excluded))
        .distinct()
        .order_by(o.plan_id.desc())
        .limit(n)
        .correlate(machine, tool)
    )
    pairs = (
        select(machine.id.label("machine_id"), tool.id.label("tool_id"))
        .select_from(machine)
        .join(tool, true())
        .where(tool.name.in_(sorted(set(tool_names))))
    )
    if dialect == "postgresql":
        newest = walk.lateral("newest")
        picked = pairs.add_columns(newest.c.plan_id).join(newest, true())
    else:
        plan = aliased(t.Plan, name="window_plan")
        picked = pairs.add_columns(plan.id.label("plan_id")).join(plan, plan.id.in_(walk))
    chosen = picked.distinct().subquery("chosen").c  # DISTINCT: read first, not flattened
    op = aliased(t.Operation, name="window_operation")
    return (
        select(op.id.label("operation_id"), chosen.plan_id, chosen.tool_id)
        .join(
            op,
            and_(
                op.tool_id == chosen.tool_id,
                op.machine_id == chosen.machine_id,
                op.plan_id == chosen.plan_id,
            ),
        )
        .subquery()
    )


def _learned() -> Exists:
    """The outer query's operation has a learned model of a quantity of its tool (a posterior)."""
    b = t.BandState
    newest = newest_state().correlate(t.Operation, t.ToolModel)
    return exists(
        select(b.id)
        .select_from(t.ToolModel)
        .join(b, b.id == newest)
        .where(t.ToolModel.tool_id == t.Operation.tool_id, b.posterior.is_not(None))
        .correlate(t.Operation)
    )


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
