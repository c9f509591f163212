"""Web view sign-ins are sessions (a lockout review): the cookie held the API key itself, so a
copied cookie was the key for every route of its role, and signing out only deleted the
browser's copy. Now the cookie holds a session's random token (``db.ui_sessions``): signing
out ends it on the server, a revoked key's sessions end and its cookie is cleared, a session
ends after its shift, and a key holds at most ``MAX_PER_KEY`` of them. A real ``rcb serve``
on SQLite and PostgreSQL.
"""

from __future__ import annotations

from datetime import timedelta

import httpx
from sqlalchemy import select
from sqlalchemy.orm import Session

from api.services.keys import create_key, revoke_key
from db import tables as t
from db import ui_sessions
from db.engine import make_engine
from db.tables import utcnow


def _browser(server) -> httpx.Client:
    base = f"http://127.0.0.1:{server.port}/ui"
    return httpx.Client(base_url=base, timeout=60.0, follow_redirects=False)


def _login(client: httpx.Client, key: str) -> httpx.Response:
    return client.post("/login", data={"key": key})


def test_revoked_key_stops_working_and_logout_ends_the_session(server):
    engine = make_engine(server.url)
    key = create_key(engine=engine, role="viewer", label="ui test")
    with _browser(server) as c:
        assert _login(c, key["key"]).status_code == 303
        assert c.get("/").status_code == 200
        revoke_key(engine=engine, key_id=key["id"])
        r = c.get("/")
        assert (r.status_code, r.headers["location"]) == (303, "/ui/login")
        assert 'rcb_ui_key=""' in r.headers["set-cookie"]  # the revoked key's cookie cleared
        assert "max-age=0" in r.headers["set-cookie"].lower()
        _login(c, server.keys["viewer"])
        assert c.get("/").status_code == 200
        copied = c.cookies["rcb_ui_key"]  # as a cookie copied out of the browser would be
        r = c.post("/logout")
        assert (r.status_code, r.headers["location"]) == (303, "/ui/login")
        assert c.get("/").status_code == 303
    with _browser(server) as thief:  # signing out ended the session on the server too
        thief.cookies.set("rcb_ui_key", copied, domain="127.0.0.1", path="/ui")
        assert thief.get("/").status_code == 303
    with Session(engine) as session:  # the sign-out deleted its row; the revoked key's went
        tokens = session.scalars(select(t.UiSession.api_key_id)).all()
    assert key["id"] not in tokens
    engine.dispose()


def test_a_session_ends_after_its_shift_and_a_key_holds_at_most_its_cap(engine):
    """A session past expires_at finds no actor; a key's 21st sign-in ends its oldest; a
    sign-in deletes every ended session."""
    key = create_key(engine=engine, role="viewer")
    other = create_key(engine=engine, role="mes")
    now = utcnow()
    with Session(engine) as session, session.begin():
        ended = ui_sessions.open_session(session=session, key_id=other["id"], now=now, lasts_s=60)
        tokens = [
            ui_sessions.open_session(session=session, key_id=key["id"], now=now, lasts_s=3600)
            for _ in range(ui_sessions.MAX_PER_KEY + 1)
        ]
    later = now + timedelta(seconds=61)
    with Session(engine) as session:
        assert ui_sessions.actor_of(session=session, token=ended, now=later) is None
        assert ui_sessions.actor_of(session=session, token=ended, now=now) is not None
        assert ui_sessions.actor_of(session=session, token=tokens[0], now=now) is None  # capped
        found = ui_sessions.actor_of(session=session, token=tokens[-1], now=later)
        assert found is not None and (found.id, found.role) == (key["id"], "viewer")
    with Session(engine) as session, session.begin():
        ui_sessions.open_session(session=session, key_id=key["id"], now=later, lasts_s=3600)
        owners = session.scalars(select(t.UiSession.api_key_id)).all()
    assert other["id"] not in owners and len(owners) == ui_sessions.MAX_PER_KEY
