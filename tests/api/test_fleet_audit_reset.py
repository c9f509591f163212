"""``rcb fleet show`` says a plan whose bands were reset made parts, none since the reset.

Found by a user's walk through two plants (2026-12-04): after ``rcb replan 2
--reset-bands`` a plan of 8 parts was listed ``no: no part reported yet``, as a plan never
run is; what it learned before is forgotten, and it counts again from its next part
(docs/concepts/fleet.md), which the row now says.
"""

from __future__ import annotations

from sqlalchemy.orm import Session
from test_fleet_db import _learned, _made

from api.services.plans import replan
from db.fleet_members import members

from conftest import engine_url, invoke


def _outs(engine) -> dict[str, str]:  # type: ignore[no-untyped-def]
    with Session(engine) as session:
        found = members(session=session, tool="CNMG432RN", after_id=0, limit=10)
    return {m.plan: m.out for m in found}


def test_a_plan_reset_is_not_said_to_have_made_no_part(engine, runner) -> None:
    a = _learned(engine, "fleet-a", 0, 2)
    _learned(engine, "fleet-b", 1, 0)
    assert replan(engine=engine, plan_id=a, changes={"reset_bands": True}).status == 201
    reset = "no part since its bands were reset (rcb replan --reset-bands)"
    assert _outs(engine) == {"fleet-a": reset, "fleet-b": "no part reported yet"}
    done = invoke(runner, "fleet", "show", "CNMG432RN", "--db", engine_url(engine))
    assert done.exit_code == 0, done.output
    assert "no part since its bands" in done.output
    assert all(len(line) <= 80 for line in done.output.splitlines() if not line.startswith("  "))
    _made(engine, a, 0, "fleet-a-again", 1)  # a part after the reset: in the fleet again
    assert _outs(engine)["fleet-a"] == ""
