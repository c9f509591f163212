"""The use cases of API keys (CLI only): create one for a role and plans, list, revoke one.

A key's label is text an operator reads in ``rcb keys list``: it is checked as a name is
(:func:`models.fields.identity`: NFKC, trimmed, no control or invisible format character, at
most :data:`models.bounds.MAX_IDENTITY` characters), empty for none. A label stored before
that check is listed as it is; the table shows it safely (:func:`api.cli.tables.shown_text`).
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import Engine
from sqlalchemy.orm import Session

from api.services import request_limits
from api.services.errors import NotFoundError
from db import api_keys, audit
from db.tables import MAX_INT
from models.errors import InputError
from models.fields import identity

#: Largest page of ``rcb keys list``.
MAX_PAGE = request_limits.KEYS_PAGE
#: Most plans one key may be scoped to.
MAX_PLANS = 1000


def create_key(
    *,
    engine: Engine,
    role: str,
    label: str = "",
    plans: list[int] | None = None,
    actor: api_keys.Actor = api_keys.CLI_ACTOR,
) -> dict[str, Any]:
    """A new API key of ``role``, printed once: ``{"key", "role", "id", "plans"}``.

    ``plans``: the plan ids the key may see (None or empty: every plan); each must exist.
    ``actor``: who creates it, for the audit log (``rcb keys create --by``).
    """
    if role not in api_keys.ROLES:
        raise InputError("--role", role, f"expected one of: {', '.join(api_keys.ROLES)}")
    label = checked_label(label)
    scope = sorted(set(plans)) if plans else None
    if scope is not None:
        if len(scope) > MAX_PLANS:
            raise InputError("--plan", len(scope), f"at most {MAX_PLANS} plans per key")
        for plan_id in scope:
            if not 1 <= plan_id <= MAX_INT:
                raise InputError("--plan", plan_id, f"a plan id is 1 to {MAX_INT}")
    with Session(engine) as session, session.begin():
        if scope is not None:
            missing = api_keys.plans_missing(session=session, plan_ids=scope)
            if missing:
                raise InputError("--plan", missing[0], "no such plan")
        key_id, key = api_keys.create_key(session=session, role=role, label=label, plans=scope)
        target = f"key {key_id}" + (f" plans {scope}" if scope else "")
        audit.audit(
            session=session, actor=actor.name, action="create key", target=target, result=role
        )
    return {"key": key, "role": role, "id": key_id, "plans": scope}


def checked_label(label: str) -> str:
    """A key's label as stored: as :func:`models.fields.identity` normalises it, "" for none.

    InputError naming ``--label``: a control character (an ESC, a newline), an invisible format
    character (a zero-width space), surrogates, blank, or more than
    :data:`models.bounds.MAX_IDENTITY` characters, the reason saying which.
    """
    if label == "":
        return ""
    try:
        return identity(label)
    except ValueError as err:
        raise InputError("--label", label, str(err)) from None


def list_keys(*, engine: Engine, after: int = 0, limit: int = 50) -> dict[str, Any]:
    """A page of keys by id, never their secret or hash: ``{"keys", "next_after"}``.

    ``after``: the cursor (the last id of the previous page, 0 for the first);
    ``next_after``: the cursor of the next page, None after the last.
    """
    if not 1 <= limit <= MAX_PAGE:
        raise InputError("--limit", limit, f"must be between 1 and {MAX_PAGE}")
    if not 0 <= after <= MAX_INT:
        raise InputError("--after", after, f"a key id is 0 to {MAX_INT}")
    with Session(engine) as session, session.begin():
        rows = api_keys.list_keys(session=session, after=after, limit=limit + 1)
        page = [
            {
                "id": row.id,
                "role": row.role,
                "label": row.label,
                "plans": row.plans,
                "created_at": row.created_at,
                "last_used_at": row.last_used_at,
                "revoked_at": row.revoked_at,
            }
            for row in rows[:limit]
        ]
    return {"keys": page, "next_after": page[-1]["id"] if len(rows) > limit else None}


def revoke_key(
    *, engine: Engine, key_id: int, actor: api_keys.Actor = api_keys.CLI_ACTOR
) -> dict[str, Any]:
    """Revoke an API key; it stays stored for the audit log (``actor``: who revokes it).

    ``already``: the key was revoked before (at ``revoked_at``); nothing changes and nothing is
    audited again.
    """
    with Session(engine) as session, session.begin():
        row, now = api_keys.revoke_key(session=session, key_id=key_id)
        if row is None:
            raise NotFoundError("ID", key_id)
        if not now:
            return {"id": key_id, "role": row.role, "revoked_at": row.revoked_at, "already": True}
        audit.audit(
            session=session,
            actor=actor.name,
            action="revoke key",
            target=f"key {key_id}",
            result="ok",
        )
        return {"id": key_id, "role": row.role, "revoked_at": row.revoked_at, "already": False}
