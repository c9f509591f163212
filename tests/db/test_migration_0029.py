"""Migration 0029: each RCB decision's ``predicted`` and ``measured``, nullable; a decision
stored before keeps every value and reads back with both null; the partial index of the marked
decisions (0028) stays partial; the downgrade drops both columns and keeps the decision."""

from __future__ import annotations

from sqlalchemy import text
from sqlalchemy.orm import Session
from test_migration_0012 import _downgrade, _quoted
from test_migrations import _columns, _no_difference

from api.services.read.plan_parts import decision_json
from db import tables as t
from db.engine import make_engine, upgrade
from db.tables import utcnow

#: A decision as 0028 stored it (flagged and noted: the partial index holds it).
OLD = {
    "quantity": "force_N",
    "action": "expand",
    "margin": 12.5,
    "band_before": 100.0,
    "band_after": 130.0,
    "dK_before": 40.0,
    "dK_after": 52.0,
    "K_before": 2280.0,
    "K_after": 2280.0,
    "flagged": True,
    "reason": "above the band",
    "flag": "above_band",
    "note": "past_limit",
}
NEW = ("predicted", "measured")


def _store(url: str) -> None:
    engine = make_engine(url)
    now = {"now": utcnow()}
    with engine.begin() as c:
        c.execute(
            text("INSERT INTO machines (name, limits, created_at) VALUES ('m', '{}', :now)"), now
        )
        c.execute(
            text(
                "INSERT INTO tools (name, process, description, material, source, created_at)"
                " VALUES ('T1', 'turning', '', '', '', :now)"
            ),
            now,
        )
        c.execute(
            text(
                "INSERT INTO plans (name, machine_id, body, current_setpoint_version,"
                " state_token, fleet_changes_accepted, created_at)"
                " VALUES ('p', 1, '{}', 1, '', 0, :now)"
            ),
            now,
        )
        c.execute(
            text(
                "INSERT INTO operations (plan_id, position, name, process, tool_id, machine_id,"
                " volume_mm3, limits, bounds, context)"
                " VALUES (1, 0, 'rough-od', 'turning', 1, 1, 1000, '{}', '{}', '{}')"
            )
        )
        c.execute(
            text(
                "INSERT INTO parts (plan_id, serial, setpoint_version, received_at)"
                " VALUES (1, 'SN-1', 1, :now)"
            ),
            now,
        )
        c.execute(
            text(
                f"INSERT INTO rcb_decisions (part_id, operation_id, {_quoted(tuple(OLD))})"
                f" VALUES (1, 1, {', '.join(':' + k for k in OLD)})"
            ),
            OLD,
        )
    engine.dispose()


def _marked_index(url: str) -> str:
    """The definition of ix_rcb_decisions_marked as the database holds it."""
    engine = make_engine(url)
    with engine.connect() as c:
        if engine.dialect.name == "postgresql":
            query = "SELECT indexdef FROM pg_indexes WHERE indexname = 'ix_rcb_decisions_marked'"
        else:
            query = "SELECT sql FROM sqlite_master WHERE name = 'ix_rcb_decisions_marked'"
        found = str(c.execute(text(query)).scalar_one())
    engine.dispose()
    return found


def _stored(url: str) -> dict[str, object]:
    engine = make_engine(url)
    with engine.connect() as c:
        row = c.execute(text("SELECT * FROM rcb_decisions")).one()._asdict()
    engine.dispose()
    return row


def test_0029_adds_predicted_and_measured_null_for_a_stored_decision(backend_url):
    upgrade(backend_url, "0028")
    _store(backend_url)
    marked = _marked_index(backend_url)
    assert "WHERE" in marked
    upgrade(backend_url)
    columns = _columns(backend_url, "rcb_decisions")
    assert all(columns[name] for name in NEW), columns  # present, nullable
    stored = _stored(backend_url)
    assert {k: stored[k] for k in NEW} == dict.fromkeys(NEW)
    assert {k: stored[k] for k in OLD} == OLD
    assert _marked_index(backend_url) == marked
    engine = make_engine(backend_url)
    with Session(engine) as session:  # the read a part's updates are made by
        shown = decision_json(session.get_one(t.RcbDecision, 1), {1: "rough-od"})
    engine.dispose()
    assert shown["predicted"] is None and shown["measured"] is None
    assert shown["band_after"] == OLD["band_after"] and shown["note"] == OLD["note"]
    _no_difference(backend_url)
    _downgrade(backend_url, "0028")
    assert not set(NEW) & set(_columns(backend_url, "rcb_decisions"))
    assert {k: v for k, v in _stored(backend_url).items() if k in OLD} == OLD
    assert _marked_index(backend_url) == marked
