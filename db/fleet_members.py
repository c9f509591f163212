"""Which stored plans using a tool make new plans' fleet priors, and why the others do not.

``rcb fleet show TOOL``: the plans whose operations use the tool, a page at a time by id,
each with its machine and whether its learned models are in the fleet (what
:func:`db.fleet.fleet_evidence` reads) or why not: an engineer took the plan or its machine
out, its process changed beyond what an engineer accepted (at which part, and whether its
readings since confirmed it or it is still to be judged: :mod:`db.fleet_changes`), it is
halted, its strategy learns no posterior, or no part was reported since its bands were last
reset, or it is older than its machine's newest plans with the tool
(:mod:`supervisor.fleet.window`). Five statements a page, however many plans use the tool and
however many parts they made.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from sqlalchemy import func, or_, select
from sqlalchemy.orm import Session
from sqlalchemy.sql.selectable import ScalarSelect, Select

from db import tables as t
from db.errors import StoredSettingsError
from db.fleet import priors_of
from db.fleet_changes import plan_changes
from db.fleet_states import newest_state
from db.fleet_window import newest_local
from db.plan_state import plan_settings
from supervisor.fleet.changes import JUDGED_AFTER
from supervisor.fleet.window import PLANS_PER_MACHINE
from supervisor.rcb.posterior import Posterior
from supervisor.rcb.posterior import from_json as posterior_from_json


@dataclass(frozen=True)
class Member:
    """A plan using the tool: in the fleet (``out`` empty) or why not; what it learned."""

    plan_id: int
    plan: str
    machine: str
    operations: tuple[str, ...]
    readings: int
    out: str
    let_go: tuple[str, ...]


def members(
    *,
    session: Session,
    tool: str,
    after_id: int,
    limit: int,
    only: frozenset[int] | None = None,
    newest_first: bool = False,
) -> list[Member]:
    """Up to ``limit`` plans using ``tool`` with id above ``after_id``, by id (module doc).

    ``only``: just these plan ids (a REST key scoped to plans), filtered in the query.
    ``newest_first``: ids below ``after_id`` (0: from the newest), so that the plans in the
    fleet, each machine's newest, come first on a tool of a year's plans.
    """
    page = _page(tool, after_id, limit, newest_first)
    if only is not None:
        page = page.where(t.Operation.plan_id.in_(sorted(only)))
    query = (
        select(t.Plan, t.Machine.name, t.Part.serial, _reset_after())
        .join(t.Machine, t.Plan.machine_id == t.Machine.id)
        .outerjoin(t.Part, t.Part.id == t.Plan.fleet_change_part)
        .where(t.Plan.id.in_(page))
        .order_by(t.Plan.id.desc() if newest_first else t.Plan.id)
    )
    plans = session.execute(query).all()
    if not plans:
        return []
    ids = [row.id for row, _, _, _ in plans]
    states = _states(session, tool, ids)
    window = newest_local([tool], session.get_bind().dialect.name)
    newest = set(session.scalars(select(window.c.plan_id).where(window.c.plan_id.in_(ids))))
    changes = plan_changes(session=session, plan_ids=ids)
    exclusions = session.scalars(
        select(t.FleetExclusion)
        .where(
            or_(
                t.FleetExclusion.plan_id.in_(ids),
                t.FleetExclusion.machine.in_({machine for _, machine, _, _ in plans}),
            )
        )
        .order_by(t.FleetExclusion.id)
    ).all()
    return [
        _member(
            row,
            machine,
            states.get(row.id, []),
            exclusions,
            (changes[row.id], serial),
            row.id in newest,
            bool(reset_after),
        )
        for row, machine, serial, reset_after in plans
    ]


def _page(tool: str, after_id: int, limit: int, newest_first: bool) -> Select[int]:
    """The ids of the tool's plans after the cursor, on ix_operations_tool_plan."""
    plan_id = t.Operation.plan_id
    if newest_first:
        after = plan_id < after_id if after_id else plan_id > 0
    else:
        after = plan_id > after_id
    return (
        select(plan_id)
        .join(t.Tool, t.Operation.tool_id == t.Tool.id)
        .where(t.Tool.name == tool, after)
        .distinct()
        .order_by(plan_id.desc() if newest_first else plan_id)
        .limit(limit)
    )


def plan_out(*, session: Session, row: t.Plan, machine: str) -> str | None:
    """Why none of the plan's learned models make a new plan's prior, whatever the tool.

    An engineer took the plan or its machine out (the reason and who), it is halted, its
    strategy learns nothing, or its process changed beyond what an engineer accepted; None
    where none holds (``rcb fleet show TOOL`` says, per tool, whether it is among its
    machine's newest plans and has learned). Three statements.
    """
    exclusions = session.scalars(
        select(t.FleetExclusion)
        .where(or_(t.FleetExclusion.plan_id == row.id, t.FleetExclusion.machine == machine))
        .order_by(t.FleetExclusion.id)
    ).all()
    count = plan_changes(session=session, plan_ids=[row.id])[row.id]
    part = None if row.fleet_change_part is None else session.get(t.Part, row.fleet_change_part)
    changes = (count, None if part is None else part.serial)
    return _why_out(row, machine, True, changes, exclusions) or None


def _reset_after() -> ScalarSelect[int | None]:
    """The part the plan's bands were last reset after (None: never reset).

    ``rcb replan --reset-bands``; correlated with ``plans``, a column of the page's first
    statement.
    """
    r = t.PlanRevision
    return (
        select(func.max(r.bands_reset_after_part))
        .where(r.plan_id == t.Plan.id, r.reset_bands.is_(True))
        .correlate(t.Plan)
        .scalar_subquery()
    )


def _states(
    session: Session, tool: str, plan_ids: Sequence[int]
) -> dict[int, list[tuple[str, t.BandState | None]]]:
    """Per plan, its operations on ``tool`` with the newest band state of each quantity."""
    b = t.BandState
    rows = session.execute(
        select(t.Operation.plan_id, t.Operation.name, b)
        .join(t.Tool, t.Operation.tool_id == t.Tool.id)
        .join(t.ToolModel, t.ToolModel.tool_id == t.Tool.id)
        .outerjoin(b, b.id == newest_state())
        .where(t.Tool.name == tool, t.Operation.plan_id.in_(plan_ids))
        .order_by(t.Operation.plan_id, t.Operation.position, t.ToolModel.quantity)
    ).all()
    out: dict[int, list[tuple[str, t.BandState | None]]] = {}
    for plan_id, operation, state in rows:
        out.setdefault(plan_id, []).append((operation, state))
    return out


def _member(
    row: t.Plan,
    machine: str,
    states: Sequence[tuple[str, t.BandState | None]],
    exclusions: Sequence[t.FleetExclusion],
    changes: tuple[int, str | None],
    newest: bool,
    reset: bool = False,
) -> Member:
    operations = tuple(dict.fromkeys(op for op, _ in states))
    beliefs = {
        (op, s.quantity): posterior_from_json(s.posterior)
        for op, s in states
        if s is not None and s.posterior is not None
    }
    starts = {k: p for k, p in priors_of(row.prior).items() if k[0] in operations}
    let_go = tuple(
        f"{op} {q}"
        for (op, q), start in starts.items()
        if max(start.prior_widening, _widening(beliefs.get((op, q)))) > 0
    )
    return Member(
        row.id,
        row.name,
        machine,
        operations,
        sum(b.observations for b in beliefs.values()),
        _why_out(row, machine, bool(beliefs), changes, exclusions, reset)
        or _older(machine, newest),
        let_go,
    )


def _older(machine: str, newest: bool) -> str:
    """Why a plan otherwise in is out: older than its machine's newest (fleet.window)."""
    return "" if newest else f"older than {machine}'s {PLANS_PER_MACHINE} newest plans with it"


def _widening(belief: Posterior | None) -> float:
    return 0.0 if belief is None else belief.prior_widening


def _why_out(
    row: t.Plan,
    machine: str,
    learned: bool,
    changes: tuple[int, str | None],
    exclusions: Sequence[t.FleetExclusion],
    reset: bool = False,
) -> str:
    """Why the plan's models are not in the fleet ("" where they are): all that holds.

    An engineer's exclusions (the plan's, its machine's) first, then what else keeps it out
    too, joined by ``; also``: ``rcb fleet include`` accepts a change listed here, which an
    exclusion or a halt must not hide (a review of a changed process).

    ``reset``: its bands were reset after a part (``rcb replan --reset-bands``): with nothing
    learned since, it has made parts, none since the reset.
    """
    taken = [
        f"taken out by {e.actor}: {e.reason}"
        if e.plan_id == row.id
        else f"machine {machine} taken out by {e.actor}: {e.reason}"
        for e in sorted(exclusions, key=lambda e: e.plan_id is None)  # the plan's first
        if e.plan_id == row.id or e.machine == machine
    ]
    return "; also ".join([*taken, *_why_else(row, learned, changes, reset)])


def _why_else(
    row: t.Plan, learned: bool, changes: tuple[int, str | None], reset: bool
) -> list[str]:
    """:func:`_why_out` but an engineer's exclusions: a halt, then a change not accepted."""
    halted = ["halted"] if row.halt is not None else []
    try:
        strategy = plan_settings(row).strategy
    except StoredSettingsError as err:  # out until an engineer sets it anew
        return [
            *halted,
            f"stored {err.setting} = {err.value!r} fails this version's check ({err.check}): "
            f"rcb replan {row.id} --rcb {err.setting}=VALUE",
        ]
    if strategy != "learn":
        return [*halted, f"strategy {strategy} learns no posterior"]
    count, serial = changes
    if count > row.fleet_changes_accepted:
        return [*halted, _changed(row, count - row.fleet_changes_accepted, serial)]
    if halted:
        return halted
    if not learned and reset:
        return ["no part since its bands were reset (rcb replan --reset-bands)"]
    if not learned:
        return ["no part reported yet"]
    return []


def _changed(row: t.Plan, unaccepted: int, serial: str | None) -> str:
    """A change not accepted: where it was counted, and judged yet or not (db.fleet_changes)."""
    # the command that accepts these and no change counted after the engineer read them
    accept = f"{unaccepted} not accepted: rcb fleet include --plan {row.id} --changes {unaccepted}"
    if row.fleet_change_part is None or serial is None:  # counted before alembic 0022
        return f"its process changed ({accept})"
    if row.fleet_change_confirmed:
        return f"its process changed at part {serial}, confirmed by its readings ({accept})"
    judged = f"judged once {JUDGED_AFTER} parts have followed it"
    return f"its process changed at part {serial}, to be {judged} ({accept})"
