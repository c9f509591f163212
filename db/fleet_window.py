"""Each machine's newest plans with a tool, in the database: the fleet's evidence bounded.

:mod:`supervisor.fleet.window` says why a machine speaks for a tool by its newest
:data:`~supervisor.fleet.window.PLANS_PER_MACHINE` plans. Here they are picked in the
statement that reads the evidence (per machine and tool, its plans that learned a model of
the tool, newest first, up to the limit): plans neither halted nor taken out by an engineer
(``fleet_exclusions``), so that one taken out lets an older one in. Each machine's walk
stops at its limit on an index (:func:`newest_local`), and the models are read for the
picked plans only, so the cost of a new plan's fleet prior is bounded by the machines, not
by the plans they made.

An imported machine (:func:`db.fleet_imported.abroad`) speaks by its newest plans the same
way, newest by when this database imported them.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from sqlalchemy import (
    CTE,
    ColumnElement,
    Exists,
    ScalarSelect,
    String,
    Subquery,
    and_,
    exists,
    func,
    literal,
    or_,
    select,
    true,
)
from sqlalchemy.orm import aliased

from db import tables as t
from db.fleet_states import newest_state
from supervisor.fleet.window import PLANS_PER_MACHINE

#: An engineer took the row's plan or its machine out of the fleet (``fleet_exclusions``).
excluded: ColumnElement[bool] = or_(
    t.FleetExclusion.plan_id == t.Plan.id, t.FleetExclusion.machine == t.Machine.name
)


def newest_local(
    tool_names: Iterable[str], dialect: str, n: int = PLANS_PER_MACHINE, every: bool = False
) -> Subquery:
    """``(operation_id, plan_id, tool_id)`` of each machine's newest ``n`` plans with each tool.

    Plans that learned a model of the tool since their bands were last reset, not halted,
    not taken out (``every``: halted and taken out too, for what the fleet left out of them,
    :mod:`db.fleet_left_out`); a plan whose process changed counts here and is left out by
    the caller.
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
        .where(o.tool_id == tool.id, o.machine_id == machine.id, _learned())
        .where(*(() if every else (t.Plan.halt.is_(None), ~exists().where(excluded))))
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


def newest_imported(
    tool_names: Iterable[str], dialect: str, n: int = PLANS_PER_MACHINE
) -> Subquery:
    """``(tool, origin, machine, plan)`` of each imported machine's newest ``n`` plans per tool.

    Newest by the last row this database imported of the plan (``imported_models.id``). The
    tool's imported machines are stepped through in order, one seek of
    ``ix_imported_models_machine_id`` each (a recursive statement, :func:`_imported_machines`);
    each machine's rows are walked from that index's end, a row kept where its plan has no
    newer one, and the walk stops at the ``n``-th plan (``LATERAL`` on PostgreSQL, ``IN`` on
    SQLite, ``dialect``, as :func:`newest_local`). The rows read are bounded by the machines
    and their newest plans, not by what was ever imported (alembic 0031).
    """
    machines = _imported_machines(sorted(set(tool_names))).c
    w, newer = aliased(t.ImportedModel, name="walked"), aliased(t.ImportedModel, name="newer")
    walk = (
        select(w.id.label("id"), w.plan.label("plan"))
        .where(w.tool == machines.tool, w.origin == machines.origin)
        .where(w.machine == machines.machine)
        .where(
            ~exists().where(
                newer.tool == w.tool,
                newer.origin == w.origin,
                newer.machine == w.machine,
                newer.plan == w.plan,
                newer.id > w.id,
            )
        )
        .order_by(w.id.desc())
        .limit(n)
    )
    found = select(machines.tool, machines.origin, machines.machine).where(
        machines.origin.is_not(None)
    )
    if dialect == "postgresql":
        newest = walk.lateral("newest")
        return found.add_columns(newest.c.plan).join(newest, true()).subquery()
    row = aliased(t.ImportedModel, name="newest_row")
    ids = walk.with_only_columns(w.id)
    return found.add_columns(row.plan).join(row, row.id.in_(ids)).subquery()


def _imported_machines(tool_names: list[str]) -> CTE:
    """``(tool, origin, machine)`` of each tool's imported machines, stepped through in order.

    Each step is the next machine of the same origin, or else the first of the next origin:
    a seek of ``ix_imported_models_machine_id`` each (a row value ``(origin, machine) > …``
    was read by SQLite as ``origin >= …``, every row of the origin). The last step's is
    ``NULL`` (the caller leaves it out).
    """
    m = t.ImportedModel

    def seek(column: Any, *where: ColumnElement[bool], of: Any = None) -> ScalarSelect[Any]:
        """``column`` of the first row where ``where`` holds; ``of``: the step's last machine."""
        found = select(column).where(*where).order_by(m.origin, m.machine).limit(1)
        return (found if of is None else found.correlate(of)).scalar_subquery()

    def first(column: Any, tool: Any) -> ScalarSelect[Any]:  # of the origin seek(origin) finds
        origin = seek(m.origin, m.tool == tool)
        return seek(column, m.tool == tool, m.origin == origin)

    seeds = [
        select(
            literal(name, String).label("tool"),
            seek(m.origin, m.tool == name).label("origin"),
            first(m.machine, name).label("machine"),
        )
        for name in tool_names or [""]
    ]
    machines = seeds[0].cte("imported_machines", recursive=True)  # the others' seeds: below
    last = machines.alias("last_machine")
    same = (m.tool == last.c.tool, m.origin == last.c.origin, m.machine > last.c.machine)
    o = aliased(t.ImportedModel, name="next_origin")
    later_origin = (  # the next origin's, from an alias: the enclosing seek reads imported_models
        select(o.origin)
        .where(o.tool == last.c.tool, o.origin > last.c.origin)
        .order_by(o.origin)
        .limit(1)
        .correlate(last)
        .scalar_subquery()
    )
    next_origin = func.coalesce(seek(m.origin, *same, of=last), later_origin)
    next_machine = func.coalesce(
        seek(m.machine, *same, of=last),
        seek(m.machine, m.tool == last.c.tool, m.origin == later_origin, of=last),
    )
    step = select(last.c.tool, next_origin, next_machine).where(last.c.origin.is_not(None))
    return machines.union_all(*seeds[1:], step)
