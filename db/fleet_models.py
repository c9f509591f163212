"""``rcb models export`` and ``import``: a tool's learned models from one database to another.

Export reads the fleet of one tool (:func:`db.fleet.fleet_evidence`: the plans of this database
and what it imported) into the document of :mod:`supervisor.fleet.document`; import checks the
whole document first and then stores each item in ``imported_models`` in one transaction, so a
bad document stores nothing. A second plant's new plan with the tool then starts where the
first one is (``rcb plans create --prior fleet``).
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import insert
from sqlalchemy.orm import Session

from db import tables as t
from db.fleet import fleet_evidence
from models.errors import InputError
from supervisor.fleet.document import document, item_json, read_document


def export_models(*, session: Session, tool: str, material: str | None = None) -> dict[str, Any]:
    """The document of ``tool``'s learned models (of work ``material`` when given).

    Raises
    ------
    InputError
        Nothing learned with the tool (on that material).
    """
    learned = [
        item
        for item in fleet_evidence(session=session, tool_names=[tool])
        if material is None or item.tool.material == material
    ]
    if not learned:
        on = "" if material is None else f" on {material!r}"
        raise InputError("TOOL", tool, f"no learn plan of this database measured it{on}")
    return document(tool, learned[0].tool.material, learned)


def import_models(*, session: Session, data: object, source: str) -> int:
    """Store a document's learned models (checked whole first); the number stored."""
    tool, learned = read_document(data)
    rows = [
        {
            "tool": tool,
            "body": item_json(item),
            "source": f"{source}: {item.plan} on {item.machine}",
        }
        for item in learned
        if item.tool.name == tool
    ]
    if len(rows) != len(learned):
        raise InputError("document.learned", tool, "holds models of another tool")
    if rows:
        session.execute(insert(t.core_table(t.ImportedModel)), rows)
    return len(rows)
