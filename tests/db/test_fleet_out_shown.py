"""Why a plan is out of the fleet is said on the plan's own surfaces (SQLite and PostgreSQL).

A web-page review: an excluded plan's page, ``GET /plans/{id}`` and ``rcb plans show`` said
nothing of it; only ``rcb fleet show TOOL`` did. Now each says it (``fleet_out``), with who
took it out and why, until an engineer puts it back; the machine's exclusion too.
"""

from __future__ import annotations

import json

import httpx
from test_fleet_db import _learned

from api.cli.main import app
from api.report.html import render_record
from api.services.fleet_models import exclude_from_fleet, include_in_fleet
from api.services.read.plans import get_plan
from api.services.read.record import report_record
from db.engine import make_engine

from conftest import demo_body, engine_url

REASON = "wrong bar stock <lot 7>"


def _out(engine, plan_id: int) -> str | None:  # type: ignore[no-untyped-def]
    return get_plan(engine=engine, plan_id=plan_id)["fleet_out"]


def test_an_excluded_plan_says_so_on_its_own_surfaces(engine, runner) -> None:
    a = _learned(engine, "fleet-a", 0, 2)
    assert _out(engine, a) is None
    exclude_from_fleet(engine=engine, plan_id=a, machine=None, reason=REASON)
    said = f"taken out by cli: {REASON}"
    assert _out(engine, a) == said
    done = runner.invoke(app, ["plans", "show", str(a), "--db", engine_url(engine)])
    assert done.exit_code == 0, done.output
    assert f"rcb: out of the fleet: {said}" in done.output
    shown = runner.invoke(app, ["plans", "show", str(a), "--json", "--db", engine_url(engine)])
    assert json.loads(shown.stdout)["fleet_out"] == said
    page = render_record(report_record(engine=engine, plan_id=a))
    assert "<dt>Out of the fleet</dt>" in page
    assert "wrong bar stock &lt;lot 7&gt;" in page  # escaped
    include_in_fleet(engine=engine, plan_id=a, machine=None)
    assert _out(engine, a) is None
    assert "Out of the fleet" not in render_record(report_record(engine=engine, plan_id=a))


def test_a_plan_on_an_excluded_machine_names_the_machine(engine) -> None:
    a = _learned(engine, "fleet-a", 0, 1)
    exclude_from_fleet(engine=engine, plan_id=None, machine="lathe-0", reason="loose spindle")
    assert _out(engine, a) == "machine lathe-0 taken out by cli: loose spindle"


def test_the_rest_answer_carries_it(server) -> None:
    with server.client("engineer") as c:
        created = c.post("/plans", json={**demo_body(), "name": "out-rest"}).json()
        assert c.get(f"/plans/{created['id']}").json()["fleet_out"] is None
    engine = make_engine(server.url)
    exclude_from_fleet(engine=engine, plan_id=created["id"], machine=None, reason="bad lot")
    engine.dispose()
    with server.client("viewer") as c:
        answer = c.get(f"/plans/{created['id']}")
    assert answer.status_code == httpx.codes.OK, answer.text
    assert answer.json()["fleet_out"] == "taken out by cli: bad lot"
