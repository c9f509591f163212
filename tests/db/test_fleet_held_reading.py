"""A plan whose first reading of a quantity was held back (implausibly low) has no belief of
it yet: the fleet leaves that quantity out and every other plan of the tool still starts.

Before alembic 0027 the state was stored with a JSON ``null`` belief, which ``IS NOT NULL``
let by: the fleet's read decoded it and every new plan with the tool failed (a 500 over REST,
a traceback at the CLI) until that plan's next reading (found by an integrator's review,
2026-12-02)."""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import Session
from test_fleet_db import LEARN, _body

from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan
from api.services.read.setpoints import current_setpoints
from db import tables as t
from db.fleet import fleet_evidence
from db.fleet_law import tool_law
from db.fleet_members import members

from conftest import report_at


def _held_first(engine) -> int:  # type: ignore[no-untyped-def]
    """A learn plan whose one part read rough-od's force at a twentieth of its prediction."""
    made = create_plan(engine=engine, body=_body("held", "lathe-0"), settings=LEARN)
    plan_id = int(made.body["id"])
    body = report_at("held-1", current_setpoints(engine=engine, plan_id=plan_id))
    force = body["operations"][0]["measurements"]["force_N"]
    force["value"] /= 20
    answer = report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
    assert answer.status == 201
    notes = {(d["operation"], d["quantity"]): d["note"] for d in answer.body["updates"]}
    assert notes[("rough-od", "force_N")] == "implausible_low"
    return plan_id


def test_a_held_first_reading_leaves_its_quantity_out_and_new_plans_start(engine) -> None:
    _held_first(engine)
    with engine.connect() as c:
        beliefs = c.execute(
            select(t.BandState.quantity, t.BandState.posterior.is_(None))
            .join(t.Operation, t.Operation.id == t.BandState.operation_id)
            .where(t.Operation.name == "rough-od")
        ).all()
    assert dict(beliefs)["force_N"] is True  # SQL NULL, not a JSON null
    with Session(engine) as session:
        learned = fleet_evidence(session=session, tool_names=["CNMG432RN"])
        law = tool_law(session=session, tool="CNMG432RN")
        page = members(session=session, tool="CNMG432RN", after_id=0, limit=10)
    assert {item.posterior.quantity for item in learned} == {"roughness_um"}
    assert [entry.quantity for entry in law] == ["roughness_um"]
    assert [m.plan for m in page] == ["held"]
    made = create_plan(engine=engine, body=_body("next", "lathe-1"), settings=LEARN)
    assert made.status == 201
    assert made.body["prior"] == "fleet"
