"""db.intake.open_report: what the first step of a part report finds and stores, on both databases.

PostgreSQL runs it as one statement (plan lock, stored answer, part insert); SQLite as separate
statements. Both must give the same answers for the same stored rows.
"""

from __future__ import annotations

import tomllib

import pytest
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from api.services.keys import create_key
from api.services.plans import create_plan
from db import idempotency
from db import tables as t
from db.engine import make_engine
from db.intake import PlanHead, open_report

from conftest import DEMO_PLAN
from migrated import migrated

PLAN = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))


@pytest.fixture
def stored(backend_url):
    """A plan at setpoint version 1, an API key, and one answer stored under key "done"."""
    migrated(backend_url)
    engine = make_engine(backend_url)
    plan_id = create_plan(engine=engine, body=PLAN).body["id"]
    key_id = create_key(engine=engine, role="mes")["id"]
    with Session(engine) as session, session.begin():
        session.execute(
            t.core_table(t.IdempotencyRecord).insert(),
            [
                idempotency.idempotency_row(key_id, "done", "h" * 64, 201, {"part_id": 7}),
                idempotency.idempotency_row(None, "cli-done", "c" * 64, 201, {"part_id": 8}),
            ],
        )
    yield engine, plan_id, key_id
    engine.dispose()


def _open(engine, plan_id, serial, version, idempotency):
    with Session(engine) as session, session.begin():
        return open_report(
            session=session,
            plan_id=plan_id,
            serial=serial,
            setpoint_version=version,
            idempotency=idempotency,
        )


def _parts(engine, plan_id):
    with Session(engine) as session:
        query = select(t.Part.serial, t.Part.setpoint_version).where(t.Part.plan_id == plan_id)
        return sorted(tuple(r) for r in session.execute(query))


def test_a_new_serial_stores_the_part_and_returns_the_plan_head(stored):
    engine, plan_id, key_id = stored
    opening = _open(engine, plan_id, "S-1", 1, (key_id, "fresh"))
    with Session(engine) as session:
        row = session.get(t.Plan, plan_id)
        expected = PlanHead(
            row.id,
            row.name,
            row.machine_id,
            row.current_setpoint_version,
            row.state_token,
            row.settings,
            row.halt,
            row.prior,
            row.noise_prior,
        )
        part_id = session.scalar(select(t.Part.id).where(t.Part.serial == "S-1"))
    assert opening.plan == expected
    assert opening.stored is None
    assert opening.part_id == part_id is not None
    assert _parts(engine, plan_id) == [("S-1", 1)]


def test_a_reported_serial_and_an_unknown_version_store_nothing(stored):
    engine, plan_id, key_id = stored
    assert _open(engine, plan_id, "S-1", 1, None).part_id is not None
    again = _open(engine, plan_id, "S-1", 1, (key_id, "other"))
    assert again.plan is not None and again.part_id is None
    for version in (0, 2, -5, 2**31, 11371909618236154445824):  # the last two: past int32
        unknown = _open(engine, plan_id, f"S-v{version}", version, None)
        assert unknown.plan is not None and unknown.part_id is None
    assert _parts(engine, plan_id) == [("S-1", 1)]


def test_no_plan(stored):
    engine, plan_id, key_id = stored
    opening = _open(engine, plan_id + 1, "S-1", 1, (key_id, "fresh"))
    assert opening.plan is None and opening.part_id is None and opening.stored is None
    with Session(engine) as session:
        assert session.scalar(select(func.count()).select_from(t.Part)) == 0


def test_a_stored_answer_is_found_and_no_part_is_stored(stored):
    engine, plan_id, key_id = stored
    opening = _open(engine, plan_id, "S-new", 1, (key_id, "done"))
    assert opening.stored is not None
    assert (opening.stored.request_hash, opening.stored.status) == ("h" * 64, 201)
    assert opening.stored.body == {"part_id": 7}
    assert opening.plan is not None and opening.part_id is None
    # the local CLI's keys (no API key) are their own; another API key's "done" is not found
    cli = _open(engine, plan_id, "S-new", 1, (None, "cli-done"))
    assert cli.stored is not None and cli.stored.body == {"part_id": 8}
    other = _open(engine, plan_id, "S-new", 1, (key_id + 1, "done"))
    assert other.stored is None and other.part_id is not None
    assert _parts(engine, plan_id) == [("S-new", 1)]
