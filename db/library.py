"""Tools and their baseline models in the database: stored, loaded back, listed."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from db import tables as t
from db.errors import ConflictError
from models.errors import InputError
from models.powerlaw import PowerLawModel
from models.tool import Tool, fields_mapping, model_fields, process_of


def ensure_tool(*, session: Session, tool: Tool) -> t.Tool:
    """The row of ``tool``, stored if new; a stored tool of that name must have the same models."""
    row = session.scalars(select(t.Tool).where(t.Tool.name == tool.name)).one_or_none()
    if row is None:
        return add_tool(session=session, tool=tool)
    stored = {q: (m.K, m.dK, dict(m.exponents)) for q, m in tool.models.items()}
    existing = {
        r.quantity: (r.K, r.dK, dict(r.exponents))
        for r in session.scalars(select(t.ToolModel).where(t.ToolModel.tool_id == row.id))
    }
    if existing != stored:
        raise ConflictError("tools.name", tool.name, "a tool of this name has other models")
    return row


def add_tool(*, session: Session, tool: Tool) -> t.Tool:
    """Store a new tool and its models; the name must be free."""
    if session.scalars(select(t.Tool.id).where(t.Tool.name == tool.name)).first() is not None:
        raise ConflictError("name", tool.name, "a tool of this name is already stored")
    row = t.Tool(
        name=tool.name,
        process=tool.process,
        description=tool.description,
        material=tool.material,
        source=tool.source,
    )
    session.add(row)
    session.flush()
    for q, m in tool.models.items():
        session.add(
            t.ToolModel(
                tool_id=row.id,
                quantity=q,
                K=m.K,
                dK=m.dK,
                exponents=dict(m.exponents),
                source=m.source,
                reference=m.reference,
            )
        )
    session.flush()
    return row


def _model(tool: str, m: t.ToolModel) -> PowerLawModel:
    """A stored model; one a later version's check refuses names the stored tool."""
    try:
        return PowerLawModel(m.quantity, m.K, m.dK, dict(m.exponents), m.source, m.reference)
    except InputError as err:
        raise _refused(tool, f"models.{err.field}", err) from None


def _tool(row: t.Tool, models: dict[str, PowerLawModel]) -> Tool:
    """A stored tool; one a later version's check refuses is named (:func:`_refused`)."""
    try:
        process = process_of(row.process, "process")
        return Tool(row.name, process, models, row.description, row.material, row.source)
    except InputError as err:
        raise _refused(row.name, err.field, err) from None


def _refused(tool: str, field: str, err: InputError) -> ConflictError:
    """A stored tool's value this version's check refuses, and the way out."""
    return ConflictError(
        f"tools.{tool}.{field}",
        err.value,
        f"{err.reason}; tool {tool} was stored under an earlier version's check, and this "
        "one refuses the plans that use it: define it anew under another name (rcb tools "
        "add FILE, POST /tools or a plan file's tools) and create those plans with it",
    )


def load_tools(
    *,
    session: Session,
    names: Iterable[str] | None = None,
    after: str | None = None,
    limit: int | None = None,
) -> dict[str, Tool]:
    """Stored tools by name (all, or those named), with their baseline models.

    ``after``, ``limit``: a page, the first ``limit`` names above ``after`` in code-point
    order (``tools.name`` is so collated, :mod:`db.tables`): an index range read of
    ``tools (name)`` and of the page's models. A tool this version's check refuses:
    :class:`~db.errors.ConflictError` naming it (:func:`tools_shown` lists it as stored).
    """
    return {
        row.name: _tool(row, {m.quantity: _model(row.name, m) for m in models})
        for row, models in _stored(session, names, after, limit)
    }


def tools_shown(
    *,
    session: Session,
    names: Iterable[str] | None = None,
    after: str | None = None,
    limit: int | None = None,
) -> dict[str, dict[str, Any]]:
    """Stored tools as a list or a page shows them: :func:`load_tools`'s in the plan-file form.

    A tool this version's check refuses keeps no other from the list: it is shown as stored,
    with ``refused`` saying which value fails and the way out.
    """
    out: dict[str, dict[str, Any]] = {}
    for row, models in _stored(session, names, after, limit):
        out[row.name] = fields_mapping(row, {m.quantity: model_fields(m) for m in models})
        try:  # the stored values are shown either way; the check adds why it refuses them
            _tool(row, {m.quantity: _model(row.name, m) for m in models})
        except ConflictError as err:
            out[row.name]["refused"] = str(err)
    return out


def _stored(
    session: Session, names: Iterable[str] | None, after: str | None, limit: int | None
) -> list[tuple[t.Tool, list[t.ToolModel]]]:
    """The tool rows (a page, or those named) by name, each with its model rows."""
    query = select(t.Tool).order_by(t.Tool.name)
    if names is not None:
        query = query.where(t.Tool.name.in_(list(names)))
    if after is not None:
        query = query.where(t.Tool.name > after)
    rows = list(session.scalars(query.limit(limit)))
    models: dict[int, list[t.ToolModel]] = {row.id: [] for row in rows}
    if rows:
        for m in session.scalars(select(t.ToolModel).where(t.ToolModel.tool_id.in_(models))):
            models[m.tool_id].append(m)
    return [(row, models[row.id]) for row in rows]
