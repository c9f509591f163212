"""The web view's sign-ins (``/ui``): a key checked once, then a session (:mod:`db.ui_sessions`).

Signing in checks the API key as every request's key is checked (wrong keys audited and
limited per client address, :func:`api.services.auth.authenticate`) and opens a session whose
random token the browser keeps; each page then finds its actor by the token, so a revoked key's
sessions end at once, and signing out ends the session on the server, not only in the browser.
"""

from __future__ import annotations

from sqlalchemy import Engine
from sqlalchemy.orm import Session

from api.services import auth
from db import ui_sessions
from db.api_keys import Actor
from db.engine import one_statement_reader
from db.tables import utcnow


def sign_in(
    *, engine: Engine, key: str, action: str, client: str, roles: tuple[str, ...], lasts_s: float
) -> tuple[str, Actor] | None:
    """A new session's token and actor for ``key``; None if it is unknown or revoked.

    None too for a role not in ``roles`` (audited as forbidden). Raises
    :class:`api.services.auth.RateLimitedError` as a key's check does.
    """
    actor = auth.authenticate(engine=engine, key=key, action=action, client=client)
    if actor is None or actor.id is None:
        return None
    if actor.role not in roles:
        auth.audit_forbidden(engine=engine, actor=actor, action=action)
        return None
    with Session(engine) as session, session.begin():
        token = ui_sessions.open_session(
            session=session, key_id=actor.id, now=utcnow(), lasts_s=lasts_s
        )
    return token, actor


def actor_of(*, engine: Engine, token: str) -> Actor | None:
    """The actor of a session's token; None if it ended, was signed out, or its key revoked.

    The key's last use is recorded as a read's.
    """
    with Session(one_statement_reader(engine)) as session:
        actor = ui_sessions.actor_of(session=session, token=token, now=utcnow())
    if actor is not None:
        auth.used(engine, actor)
    return actor


def sign_out(*, engine: Engine, token: str) -> None:
    """End the session of ``token`` on the server (nothing if it had ended)."""
    with Session(engine) as session, session.begin():
        ui_sessions.close_session(session=session, token=token)
