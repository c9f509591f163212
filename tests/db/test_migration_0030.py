"""Migration 0030: ``ui_sessions``, the web view's sign-ins (a lockout review: the cookie held
the API key). Upgraded, the schema is the tables'; a session goes with its key (``ON DELETE
CASCADE``); the downgrade drops the table and keeps the keys, and upgrading again works."""

from __future__ import annotations

from sqlalchemy import inspect, text
from sqlalchemy.orm import Session
from test_migration_0012 import _downgrade
from test_migrations import _no_difference

from api.services.keys import create_key
from db import tables as t
from db import ui_sessions
from db.engine import make_engine, upgrade
from db.tables import utcnow


def _tables(url: str) -> set[str]:
    engine = make_engine(url)
    try:
        with engine.connect() as connection:
            return set(inspect(connection).get_table_names())
    finally:
        engine.dispose()


def test_0030_up_down_and_a_session_goes_with_its_key(backend_url):
    upgrade(backend_url)
    _no_difference(backend_url)
    engine = make_engine(backend_url)
    kept = create_key(engine=engine, role="viewer")["id"]
    gone = create_key(engine=engine, role="viewer")["id"]
    with Session(engine) as session, session.begin():
        for key_id in (kept, gone):
            ui_sessions.open_session(session=session, key_id=key_id, now=utcnow(), lasts_s=60)
    with engine.begin() as c:
        c.execute(text("DELETE FROM api_keys WHERE id = :id"), {"id": gone})
    with Session(engine) as session:
        owners = session.query(t.UiSession.api_key_id).all()
    engine.dispose()
    assert [o[0] for o in owners] == [kept]
    _downgrade(backend_url, "0029")
    assert "ui_sessions" not in _tables(backend_url) and "api_keys" in _tables(backend_url)
    upgrade(backend_url)
    _no_difference(backend_url)
