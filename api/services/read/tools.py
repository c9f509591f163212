"""The tools: the packaged catalogue and the stored tools, one by name or a page at a time.

A stored tool replaces a catalogue tool of its name. A stored tool this version's check refuses
is shown as stored, with ``refused`` (:func:`db.library.tools_shown`): it keeps no other from
the list.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from sqlalchemy import Engine

from api.services import to_json
from api.services.errors import NotFoundError
from api.services.read.common import LIST_PAGE, _bounded, _read, _token, _untoken
from db import library
from models.catalogue import catalogue
from models.tool import Tool


def get_tool(*, engine: Engine, name: str) -> dict[str, Any]:
    """One tool with its baseline models and provenance."""
    with _read(engine) as session, session.begin():
        stored = library.tools_shown(session=session, names=[name])
    if name in stored:  # as stored, with why this version refuses it if it does
        return stored[name]
    tool = catalogue().get(name)
    if tool is None:
        raise NotFoundError("name", name)
    return to_json.tool_json(tool)


def stored_tool(*, engine: Engine, name: str) -> Tool | None:
    """The stored tool ``name`` as plans use it, or None when the database holds none.

    One this version's check refuses: :class:`~db.errors.ConflictError` naming the value.
    """
    with _read(engine) as session, session.begin():
        return library.load_tools(session=session, names=[name]).get(name)


def list_tools(
    *, engine: Engine, cursor: str | None = None, page_size: int = LIST_PAGE
) -> dict[str, Any]:
    """A page of the packaged catalogue and the stored tools, by name (code-point order).

    A stored tool replaces a catalogue tool of its name. Only the page's stored tools are read.
    """
    _bounded(page_size)
    after = str(_untoken(cursor, 1)[0]) if cursor is not None else ""  # names are not empty
    with _read(engine) as session, session.begin():
        stored = library.tools_shown(session=session, after=after, limit=page_size + 1)
    packaged = {n: tool for n, tool in catalogue().items() if n > after}
    names = sorted({*packaged, *stored})
    if len(stored) > page_size:  # stored names past the last one read might come before
        names = [n for n in names if n <= max(stored)]
    page = names[:page_size]
    more = len(names) > page_size
    return {
        "tools": [stored[n] if n in stored else to_json.tool_json(packaged[n]) for n in page],
        "next_cursor": _token([page[-1]]) if more else None,
    }


def tools_of_plan(*, engine: Engine, body: object) -> dict[str, Tool]:
    """The stored tools a plan file's operations name, as ``rcb plans create`` looks them up."""
    from api.services.plans import named_tools

    if not isinstance(body, Mapping):  # the plan's reader refuses it, naming what it is
        return {}
    with _read(engine) as session, session.begin():
        return named_tools(session, body)
