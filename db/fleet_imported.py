"""The machines whose models this database imported, by the names the fleet gives them.

:func:`imported_evidence` reads their models for a new plan's prior (each machine's newest
plans, :func:`db.fleet_window.newest_imported`), a machine taken out left unread, and names
the machine of a stored model this version refuses with the command that takes it out
(:func:`stale`). ``rcb fleet imported TOOL`` (``GET /tools/{name}/fleet/imported``) lists
them a page at a time, each in the fleet or taken out (and by whom, why), under the name an
engineer takes one out by (``rcb fleet exclude --machine lathe-1@6f1c2a3b``, :func:`abroad`).
One grouped statement on ``imported_models`` (by ``ix_imported_models_tool``, from the page's
key on) and one seek per name on ``fleet_exclusions``: no cost grows with the pages before.
:func:`imported_in_fleet` counts the tool's imported models whose machine is not taken out.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from sqlalchemy import ColumnElement, and_, case, exists, func, literal, or_, select
from sqlalchemy.orm import Session

from db import tables as t
from db.fleet_window import newest_imported
from models.errors import Gathered, InputError
from supervisor.fleet.document import read_item
from supervisor.fleet.learned import Learned


def abroad(machine: str, origin: str) -> str:
    """An imported model's machine as the fleet tells it apart: ``lathe-1@6f1c2a3b``.

    Two plants may both have a ``lathe-1``; merged by name, a new plan on this plant's would
    take the other's readings for its own machine's, which the between-machine spread does not
    limit. The first 8 characters of the origin's UUID (``imported`` where a version 1
    document did not say) keep them apart, and say where each machine is. An imported plan
    is named so too (``fleet-a@6f1c2a3b``): two plants' ``fleet-a`` are two plans, counted
    apart in a prior's provenance (``prior from 2 plans on 2 machines``, not ``1 plan``).
    """
    return f"{machine}@{origin[:8] or 'imported'}"


#: The imported machines one statement reads the newest plans of: each is a term of an ``OR``
#: that SQLite nests one level deeper a term (its expressions stop at a depth of 1000).
_MACHINES_A_STATEMENT = 200


def imported_evidence(*, session: Session, tool_names: Iterable[str]) -> list[tuple[str, Learned]]:
    """The models of the named tools other databases exported, each with its ``origin``.

    Left out: those of a machine an engineer took out by its name here (``rcb fleet exclude
    --machine lathe-1@6f1c2a3b``, :func:`abroad`), before they are read.

    Raises
    ------
    InputError
        A row this version refuses (imported before it checked so: :func:`stale`), one error
        per machine (:class:`~models.errors.InputErrors` for several).
    """
    names = sorted(set(tool_names))
    dialect = session.get_bind().dialect.name
    # the window first, then its plans' rows, a seek of uq_imported_models_key a plan: joined
    # in one statement, SQLite read every row of the tool (4.2 s at 100 000 rows)
    picked: dict[tuple[str, str, str], list[str]] = {}
    for tool, origin, machine, plan in session.execute(select(newest_imported(names, dialect))):
        picked.setdefault((tool, origin, machine), []).append(plan)
    out = taken_out(session=session, names={abroad(machine, o) for _, o, machine in picked})
    m = t.ImportedModel
    machines = sorted(k for k in picked if abroad(k[2], k[1]) not in out)  # out: not read
    rows: list[Any] = []
    for at in range(0, len(machines), _MACHINES_A_STATEMENT):
        chosen = [
            and_(m.tool == tool, m.origin == origin, m.machine == machine, m.plan.in_(plans))
            for tool, origin, machine in machines[at : at + _MACHINES_A_STATEMENT]
            for plans in [picked[(tool, origin, machine)]]
        ]
        found = select(m.id, m.origin, m.machine, m.body, m.source).where(or_(*chosen))
        rows += list(session.execute(found))
    rows.sort(key=lambda row: row[0])  # in the order they were imported
    read: list[tuple[str, Learned]] = []
    refused = Gathered()
    named: set[str] = set()
    for row in rows:
        try:
            read.append((row.origin, read_item(row.body, "imported_models.body")))
        except InputError as err:
            name = abroad(row.machine, row.origin)
            if name not in named:  # one error per machine: one exclusion takes it out
                named.add(name)
                refused.read(stale, err, name, row.source)
    refused.raise_any()
    return read


def stale(err: InputError, machine: str, source: str) -> None:
    """Raise ``err`` of an imported row this version refuses, saying whose it is and the way out.

    ``rcb models import`` stored, before it checked so, models this version refuses (an
    operation without a bound its model needs, of another process). Dropped unasked, a plant's
    machine would leave the fleet with no one knowing; refused unnamed, no new plan of the tool
    could start from the fleet, and the error named only ``imported_models.body…``. The error
    names the machine as an engineer takes it out, and the command: taken out, its rows are
    not read (:func:`imported_evidence`), and ``rcb fleet include`` puts it back.
    """
    raise InputError(
        err.field,
        err.value,
        f"{err.reason} (a model of imported machine {machine}, {source}, stored before this"
        f" version checked it: take the machine out of the fleet with `rcb fleet exclude"
        f" --machine {machine} --reason TEXT`, or create the plan with --prior catalogue)",
    )


def taken_out(*, session: Session, names: Iterable[str]) -> dict[str, str]:
    """Of the named imported machines (:func:`abroad`), those an engineer took out, and why.

    One seek per name on ``fleet_exclusions``: ``taken out by ACTOR: REASON``.
    """
    wanted = sorted(set(names))
    if not wanted:
        return {}
    e = t.FleetExclusion
    found = select(e.machine, e.actor, e.reason).where(e.machine.in_(wanted)).order_by(e.id)
    return {str(m): f"taken out by {actor}: {why}" for m, actor, why in session.execute(found)}


def imported_machine(*, session: Session, name: str) -> bool:
    """Whether ``name`` is an imported model's machine as :func:`abroad` names it."""
    machine, _, short = name.rpartition("@")
    m = t.ImportedModel
    origin = m.origin == "" if short == "imported" else m.origin.startswith(short)
    found = select(m.id).where(m.machine == machine, origin).limit(1)
    return bool(machine and short) and session.scalar(found) is not None


@dataclass(frozen=True)
class ImportedMachine:
    """An imported machine's models of a tool: how many, on how many readings, in or out."""

    machine: str
    models: int
    readings: int
    out: str  # why not in the fleet ("" where it is)


def imported_machines(
    *, session: Session, tool: str, after: tuple[str, str] | None, limit: int
) -> list[tuple[tuple[str, str], ImportedMachine]]:
    """Up to ``limit`` imported machines of ``tool`` after the key ``after``, each by its key.

    The key is the machine's stored (name, origin); the page's order is the keys'.
    """
    m = t.ImportedModel
    query = select(m.machine, m.origin, func.count(), func.sum(m.observations)).where(
        m.tool == tool
    )
    if after is not None:
        query = query.where(
            or_(m.machine > after[0], and_(m.machine == after[0], m.origin > after[1]))
        )
    groups = session.execute(
        query.group_by(m.machine, m.origin).order_by(m.machine, m.origin).limit(limit)
    ).all()
    named = [(abroad(machine, origin), machine, origin, n, r) for machine, origin, n, r in groups]
    out = taken_out(session=session, names=[name for name, *_ in named])
    return [
        (
            (machine, origin),
            ImportedMachine(name, int(count), int(readings or 0), out.get(name, "")),
        )
        for name, machine, origin, count, readings in named
    ]


def imported_in_fleet(*, session: Session, tool: str) -> int:
    """``tool``'s imported models whose machine no engineer took out (one counting statement).

    None: a new plan with no stored plan of the tool starts from the catalogue
    (``rcb fleet show`` says so), whatever was imported.
    """
    m, e = t.ImportedModel, t.FleetExclusion
    out = exists().where(e.machine == _abroad_name())
    found = session.scalar(select(func.count()).select_from(m).where(m.tool == tool, ~out))
    return int(found or 0)


def imported_machines_in_fleet(*, session: Session, tool: str) -> int:
    """How many machines ``tool``'s imported models are on, none taken out (one statement)."""
    m, e = t.ImportedModel, t.FleetExclusion
    out = exists().where(e.machine == _abroad_name())
    machines = select(m.machine, m.origin).where(m.tool == tool, ~out).distinct().subquery()
    return int(session.scalar(select(func.count()).select_from(machines)) or 0)


def _abroad_name() -> ColumnElement[str]:
    """:func:`abroad` in SQL: ``machine@`` the origin's first 8 characters."""
    m = t.ImportedModel
    short = case((m.origin == "", literal("imported")), else_=func.substr(m.origin, 1, 8))
    return m.machine + literal("@") + short
