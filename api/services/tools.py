"""The use case that stores a new tool with its baseline models."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from sqlalchemy import Engine
from sqlalchemy.orm import Session

from api.services import to_json
from api.services.idempotency import Idempotency, Written
from api.services.transactions import audited, write
from db import api_keys, library
from db.api_keys import Actor
from db.errors import ConflictError
from models.catalogue import catalogue
from models.tool import tool_from_mapping


def add_tool(
    *,
    engine: Engine,
    body: Mapping[str, Any],
    actor: Actor = api_keys.CLI_ACTOR,
    idempotency: Idempotency | None = None,
) -> Written:
    """Store a new tool with its baseline models (status 201); the name must be new."""
    with audited(engine, actor, "add tool", f"tool {body.get('name', '')}"):
        tool = tool_from_mapping(body, "")
        if tool.name in catalogue():
            raise ConflictError("name", tool.name, "a catalogue tool has this name")

        def work(session: Session) -> tuple[int, dict[str, Any]]:
            library.add_tool(session=session, tool=tool)
            return 201, to_json.tool_json(tool)

        return write(
            engine,
            actor=actor,
            action="add tool",
            target=f"tool {tool.name}",
            idempotency=idempotency,
            work=work,
        )
