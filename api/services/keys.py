"""The use cases of API keys (CLI only): create one for a role, revoke one."""

from __future__ import annotations

from typing import Any

from sqlalchemy import Engine
from sqlalchemy.orm import Session

from api.services.errors import NotFoundError
from db import access
from models.errors import InputError


def create_key(*, engine: Engine, role: str, label: str = "") -> dict[str, Any]:
    """A new API key of ``role``, printed once: ``{"key", "role", "id"}``."""
    if role not in access.ROLES:
        raise InputError("--role", role, f"expected one of: {', '.join(access.ROLES)}")
    with Session(engine) as session, session.begin():
        key_id, key = access.create_key(session=session, role=role, label=label)
        access.audit(
            session=session, actor="cli", action="create key", target=f"key {key_id}", result=role
        )
    return {"key": key, "role": role, "id": key_id}


def revoke_key(*, engine: Engine, key_id: int) -> dict[str, Any]:
    """Revoke an API key; it stays stored for the audit log."""
    with Session(engine) as session, session.begin():
        row = access.revoke_key(session=session, key_id=key_id)
        if row is None:
            raise NotFoundError("ID", key_id)
        access.audit(
            session=session, actor="cli", action="revoke key", target=f"key {key_id}", result="ok"
        )
        return {"id": key_id, "role": row.role, "revoked_at": row.revoked_at}
