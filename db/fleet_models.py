"""``rcb models export`` and ``import``: a tool's learned models from one database to another.

Export reads the fleet of one tool (:func:`db.fleet.fleet_evidence`: the plans of this database
and what it imported) into the document of :mod:`supervisor.fleet.document`, each model with
the database that learned it (``origin``: for this one's plans, the identity they were created
under, :func:`db.identity.plan_origins`). Import checks the whole document first and then
stores its items in ``imported_models`` in one transaction, so a bad document stores nothing,
and counts each model once:

- a model whose plan this database holds under the model's origin is skipped (it already
  counts here: a model that went to a second plant and came back, or one of the plans a
  copied database was copied with);
- a model already imported (the same origin, machine, plan, operation and quantity) is
  replaced by the document's if that one has at least as many readings (a newer export of
  the same plans), else kept (an older file imported after a newer one).

Imported twice, the same document thus changes nothing. A second plant's new plan with the tool
then starts where the first one is (``rcb plans create --prior fleet``). A model that carries
this database's identity and a plan it does not hold comes from a copy of this database that
kept its identity: it is stored, and counted apart (``copied``) so that the import can say so.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import asdict, dataclass
from typing import Any

from sqlalchemy import func, insert, select
from sqlalchemy.orm import Session

from db import tables as t
from db.fleet import local_evidence
from db.fleet_imported import imported_evidence, imported_machines_in_fleet
from db.identity import database_id, plan_origins
from models.catalogue import catalogue
from models.errors import InputError
from supervisor.fleet.document import (
    MAX_IMPORTED_MACHINES,
    document,
    item_json,
    read_document,
)
from supervisor.fleet.learned import Learned


def export_models(*, session: Session, tool: str, material: str | None = None) -> dict[str, Any]:
    """The document of ``tool``'s learned models (of work ``material`` when given).

    Raises
    ------
    InputError
        Nothing learned with the tool (on that material).
    """
    local = local_evidence(session=session, tool_names=[tool])
    own = database_id(session=session)
    origins = plan_origins(session=session, names=(item.plan for item in local), own=own)
    held = [
        *((origins[x.plan], x) for x in local),
        *imported_evidence(session=session, tool_names=[tool]),
    ]
    learned = [(o, item) for o, item in held if material is None or item.tool.material == material]
    if not learned:
        reason = _not_learned(session, tool, material, [item for _, item in held])
        if material is not None and held:  # the tool was learned, on another material
            raise InputError("--material", material, reason)
        raise InputError("TOOL", tool, reason)
    return document(tool, learned[0][1].tool.material, learned)


def _not_learned(session: Session, tool: str, material: str | None, held: list[Learned]) -> str:
    """Why nothing of ``tool`` (on ``material``) can be exported: no such tool, or no model."""
    stored = session.scalar(select(t.Tool.id).where(t.Tool.name == tool))
    if stored is None and tool not in catalogue():
        return "no such tool in the catalogue or the database"
    if material is None:
        used = session.scalar(
            select(t.Operation.id)
            .join(t.Tool, t.Operation.tool_id == t.Tool.id)
            .where(t.Tool.name == tool)
            .limit(1)
        )
        if used is not None:  # its plans are out, halted or have learned nothing yet
            return f"no plan in the fleet learned it (rcb fleet show {tool}: each plan and why)"
        return "no learn plan of this database measured it"
    materials = sorted({item.tool.material for item in held})
    on = f"; it was measured on {', '.join(map(repr, materials))}" if materials else ""
    return f"no learn plan of this database measured it on {material!r}{on}"


@dataclass(frozen=True)
class Imported:
    """What an import did with a document's models (each counted in one of these)."""

    new: int
    replaced: int
    kept: int  # already held, the same or with more readings
    own: int  # learned by plans this database holds
    copied: int = 0  # of new, replaced and kept: this database's identity, a plan not held

    def to_json(self) -> dict[str, int]:
        """``{"stored": new + replaced, "new": …, "replaced": …, "kept": …, "own": …, …}``."""
        return {"stored": self.new + self.replaced, **asdict(self)}


def import_models(*, session: Session, data: object, source: str) -> Imported:
    """Store a document's learned models (checked whole first; module docstring)."""
    tool, learned = read_document(data)
    for i, (_, item) in enumerate(learned):
        if item.tool.name != tool:
            raise InputError(
                f"document.learned[{i}].tool.name",
                item.tool.name,
                f"the document's tool is {tool!r}",
            )
    _one_machine_a_plan(session, tool, learned)
    own = database_id(session=session)
    held = plan_origins(session=session, names=(item.plan for _, item in learned), own=own)
    foreign = [(o, item) for o, item in learned if held.get(item.plan) != o]
    rows = _rows(tool, foreign, source)
    stored = _held(session, tool, rows.keys())
    fresh = [row for key, row in rows.items() if key not in stored]
    if fresh:  # one statement for them all (a document holds up to 25 000)
        session.execute(insert(t.core_table(t.ImportedModel)), fresh)
    replaced = 0
    for key, old in stored.items():
        row = rows[key]
        if (old.observations, old.body) != (row["observations"], row["body"]) and (
            old.observations <= row["observations"]
        ):  # a newer export of the model (the same one again is kept as it is)
            for name in ("body", "source", "observations"):
                setattr(old, name, row[name])
            old.imported_at = t.utcnow()
            replaced += 1
    session.flush()
    if fresh:  # all imports together: each machine's newest plans are read by a fleet prior
        machines = imported_machines_in_fleet(session=session, tool=tool)
        if machines > MAX_IMPORTED_MACHINES:
            raise InputError(
                "document.learned",
                f"{len(learned)} models",
                f"would put {tool!r}'s imported models on {machines} machines in the fleet,"
                f" more than {MAX_IMPORTED_MACHINES} (each new plan's fleet prior reads every"
                " one): take machines out first (rcb fleet imported, rcb fleet exclude"
                " --machine) or import fewer; nothing was stored",
            )
    copied = sum(1 for origin, _ in foreign if origin == own)
    new, own_count = len(fresh), len(learned) - len(foreign)
    return Imported(new, replaced, len(foreign) - new - replaced, own_count, copied)


def _one_machine_a_plan(session: Session, tool: str, learned: list[tuple[str, Learned]]) -> None:
    """Refuse an item whose plan the document or a stored import has on another machine.

    A plan runs on one machine (a database names a plan once): a hand-edited document that
    moved some of a plan's models to another machine would be counted as one plan on two,
    its readings split between them. Of a version 1 document (no ``origin``), two plants'
    plans of one name cannot be told apart: not checked. One statement for the stored rows.
    """
    first: dict[tuple[str, str], tuple[int, str]] = {}
    for i, (origin, item) in enumerate(learned):
        seen = first.setdefault((origin, item.plan), (i, item.machine))
        if origin and seen[1] != item.machine:
            raise InputError(
                f"document.learned[{i}].machine",
                item.machine,
                f"plan {item.plan!r} of {origin} runs on one machine; learned[{seen[0]}] is on"
                f" {seen[1]!r}",
            )
    m = t.ImportedModel
    origins = sorted({origin for origin, _ in first if origin})
    if not origins:
        return
    stored = session.execute(
        select(m.origin, m.plan, m.machine, func.min(m.source))
        .where(m.tool == tool, m.origin.in_(origins))  # uq_imported_models_key
        .group_by(m.origin, m.plan, m.machine)
    )
    for origin, plan, machine, source in stored:
        i, given = first.get((origin, plan), (-1, machine))
        if given != machine:
            raise InputError(
                f"document.learned[{i}].machine",
                given,
                f"plan {plan!r} of {origin} runs on one machine; it is stored on {machine!r}"
                f" ({source})",
            )


def _rows(
    tool: str, learned: list[tuple[str, Learned]], source: str
) -> dict[tuple[str, ...], dict[str, Any]]:
    """The rows of ``learned`` by key; of a key given twice, the one with more readings."""
    rows: dict[tuple[str, ...], dict[str, Any]] = {}
    for origin, item in learned:
        row: dict[str, Any] = {
            "tool": tool,
            "origin": origin,
            "machine": item.machine,
            "plan": item.plan,
            "operation": item.operation.name,
            "quantity": item.posterior.quantity,
            "observations": item.posterior.observations,
            "body": item_json(item),
            "source": f"{source}: {item.plan} on {item.machine}",
        }
        key = tuple(str(row[name]) for name in _KEY)
        if key not in rows or rows[key]["observations"] <= row["observations"]:
            rows[key] = row
    return rows


#: What makes two imported rows one learned model (``uq_imported_models_key``).
_KEY = ("tool", "origin", "machine", "plan", "operation", "quantity")


def _held(
    session: Session, tool: str, keys: Collection[tuple[str, ...]]
) -> dict[tuple[str, ...], t.ImportedModel]:
    """The tool's imported rows of ``keys``, by key (one statement, the key's index)."""
    m = t.ImportedModel
    origins = sorted({key[1] for key in keys})
    found = session.scalars(select(m).where(m.tool == tool, m.origin.in_(origins)))
    by_key = {tuple(str(getattr(row, name)) for name in _KEY): row for row in found}
    return {key: row for key, row in by_key.items() if key in keys}
