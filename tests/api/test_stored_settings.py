"""A plan whose stored RCB settings fail this version's check locks nothing and no one out.

A check tightened in a later release (``z`` below 1 before migration 0025) leaves stored
settings that fail it. Before, ``rcb plans`` and ``GET /plans`` failed for every plan, naming
the plan's value as an option (``--alpha = 5.0: must be a number in (0, 1]``); the fleet read
every learning plan's settings, so one such plan failed every new plan of its tools (``rcb
plans create`` and ``rcb fleet show`` exited 2); and ``rcb replan PLAN --rcb alpha=0.3``, the
repair, failed on the stored value before applying the given one: only a migration freed it.

Now the list shows such a plan's settings as stored; the learner refuses its reports (409
``stored_settings_refused``, naming the plan, the setting and the repair); the fleet leaves
its evidence out and says why; a replan that sets the refused values anew frees it.
"""

from __future__ import annotations

import copy
from typing import Any

import pytest
from sqlalchemy import create_engine, update
from sqlalchemy.orm import Session
from test_fleet_db import LEARN, _body, _learned
from test_service import BODY
from test_ui import _browser, _login, _text, _xml
from typer.testing import CliRunner

from api.cli.main import app
from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan, replan
from api.services.read.plans import get_plan, list_plans
from api.services.read.setpoints import current_setpoints
from db import tables as t
from db.errors import StoredSettingsError
from db.fleet_members import members
from models.errors import InputError

from conftest import engine_url, report_at

#: Values this version refuses: ``alpha`` in (0, 1], ``z`` at least 1 (migration 0025).
FAILING = {"alpha": 5.0, "z": 0.5}


def _store(engine, plan_id: int, values: dict[str, Any]) -> dict[str, Any]:  # type: ignore[no-untyped-def]
    """``values`` written over plan ``plan_id``'s stored settings; the settings before."""
    with engine.begin() as c:
        stored = c.execute(t.Plan.__table__.select().where(t.Plan.id == plan_id)).one().settings
        c.execute(update(t.Plan).where(t.Plan.id == plan_id).values(settings={**stored, **values}))
    return dict(stored)


def _report(engine, plan_id: int, serial: str):  # type: ignore[no-untyped-def]
    setpoints = current_setpoints(engine=engine, plan_id=plan_id)
    return report_part(
        engine=engine, plan_id=plan_id, report=parse_report(report_at(serial, setpoints))
    )


def test_the_list_shows_the_stored_values_and_every_other_plan(engine):
    first = create_plan(engine=engine, body=BODY).body["id"]
    second = copy.deepcopy(BODY)
    second["name"] = "second-plan"
    other = create_plan(engine=engine, body=second).body["id"]
    stored = _store(engine, first, FAILING)
    page = list_plans(engine=engine)["plans"]
    assert [p["id"] for p in page] == [first, other]
    shown, fine = page
    assert (shown["alpha"], shown["settings"]["z"]) == (5.0, 0.5)  # as stored, not replaced
    assert shown["settings"]["coverage_k"] == stored["coverage_k"]
    assert (fine["alpha"], fine["settings"]["z"]) == (0.25, 4.0)  # the defaults
    assert get_plan(engine=engine, plan_id=first)["alpha"] == 5.0  # a read, as listed
    assert f"rcb replan {first} --rcb alpha=VALUE" in shown["settings_refused"]
    assert fine["settings_refused"] is None
    # the learner refuses them, naming the plan, the value and the repair
    with pytest.raises(StoredSettingsError) as refused:
        _report(engine, first, "SN-1")
    assert (refused.value.field, refused.value.value) == ("settings.alpha", 5.0)
    assert f"plan {first} ({BODY['name']})" in str(refused.value)
    assert f"rcb replan {first} --rcb alpha=VALUE" in str(refused.value)


def test_a_replan_that_sets_the_refused_values_anew_frees_the_plan(engine):
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    stored = _store(engine, plan_id, FAILING)
    with pytest.raises(StoredSettingsError, match="settings.z = 0.5"):  # alpha given, z not
        replan(engine=engine, plan_id=plan_id, changes={"rcb": {"alpha": 0.3}})
    with pytest.raises(InputError, match=r"alpha = 2\.0"):  # a given value: its own check
        replan(engine=engine, plan_id=plan_id, changes={"rcb": {"alpha": 2.0, "z": 3}})
    repair = {"rcb": {"alpha": 0.3, "z": 3}}
    tried = replan(engine=engine, plan_id=plan_id, changes=repair, dry_run=True)
    assert tried.status == 200
    with pytest.raises(StoredSettingsError):  # a dry run stored nothing and cached nothing
        _report(engine, plan_id, "SN-1")
    assert replan(engine=engine, plan_id=plan_id, changes=repair).status == 201
    shown = get_plan(engine=engine, plan_id=plan_id)
    assert (shown["alpha"], shown["settings"]["z"]) == (0.3, 3.0)
    assert shown["settings"]["coverage_k"] == stored["coverage_k"]  # the rest as stored
    assert _report(engine, plan_id, "SN-1").status == 201  # it learns again


def test_rcb_plans_and_plans_show_say_refused_and_the_repair_within_80_columns(engine):
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    _store(engine, plan_id, {"alpha": 5.0})
    url = engine_url(engine)
    runner = CliRunner()
    for args in (["plans"], ["plans", "show", str(plan_id)]):
        done = runner.invoke(app, [*args, "--db", url], env={"COLUMNS": "80"})
        assert done.exit_code == 0, done.output
        assert "REFUSED" in done.stdout + done.stderr
        said = [line for line in done.stderr.splitlines() if line]
        assert all(len(line) <= 80 for line in said), said
        told = " ".join(line.strip() for line in said)
        assert f"rcb: plan {plan_id} REFUSED: settings.alpha = 5.0" in told
        assert f"set it anew: rcb replan {plan_id} --rcb alpha=VALUE" in told


def _fleet_reasons(engine, tool: str) -> dict[str, str]:  # type: ignore[no-untyped-def]
    with Session(engine) as session:
        return {m.plan: m.out for m in members(session=session, tool=tool, after_id=0, limit=10)}


def _plans_behind(engine, name: str) -> list[str]:  # type: ignore[no-untyped-def]
    made = create_plan(engine=engine, body=_body(name, f"lathe-{name}"), settings=LEARN).body
    return [] if made["prior"] == "catalogue" else made["provenance"]["rough-od"][0]["plans"]


def test_a_plan_whose_settings_are_refused_leaves_the_fleet_and_says_why(engine):
    a = _learned(engine, "fleet-a", 0, 3)
    _learned(engine, "fleet-b", 1, 3)
    _store(engine, a, {"alpha": 5.0})
    assert _plans_behind(engine, "c1") == ["fleet-b"]  # before: alpha = 5.0 refused c1
    tool = BODY["operations"][0]["tool"]
    out = _fleet_reasons(engine, tool)
    assert out["fleet-b"] == ""
    assert out["fleet-a"].startswith("stored alpha = 5.0 fails this version's check")
    assert out["fleet-a"].endswith(f"rcb replan {a} --rcb alpha=VALUE")
    replan(engine=engine, plan_id=a, changes={"rcb": {"alpha": 0.25}})
    assert _plans_behind(engine, "c2") == ["fleet-a", "fleet-b"]
    assert _fleet_reasons(engine, tool)["fleet-a"] == ""


def test_over_rest_a_refused_report_is_a_409_naming_the_repair_and_a_replan_frees_it(server):
    with server.client("engineer") as eng, server.client("mes") as mes:
        body = {**copy.deepcopy(BODY), "name": "stored-settings-rest"}
        plan_id = eng.post("/plans", json=body).json()["id"]
        database = create_engine(server.url)
        _store(database, plan_id, {"alpha": 5.0})
        database.dispose()
        report = report_at("SN-1", mes.get(f"/plans/{plan_id}/setpoints").json())
        key = {"Idempotency-Key": "stored-settings-1"}
        refused = mes.post(f"/plans/{plan_id}/parts", json=report, headers=key)
        assert refused.status_code == 409, refused.text
        problem = refused.json()
        assert (problem["code"], problem["field"], problem["value"]) == (
            "stored_settings_refused",
            "settings.alpha",
            5.0,
        )
        assert f'POST /plans/{plan_id}/replan {{"rcb": {{"alpha": VALUE}}}}' in problem["detail"]
        assert "rcb replan" in eng.get(f"/plans/{plan_id}").json()["settings_refused"]
        with _browser(server) as page:  # the web view's list says so, the reason opens under
            _login(page, server.keys["viewer"])  # it (a title on hover: no keyboard, no touch)
            root = _xml(page.get("/").text)
        row = root.find(f".//table[@id='plans']/tbody/tr[@data-plan='{plan_id}']")
        assert row is not None
        status = row.findall("td")[6]
        said = status.find("details/summary")
        assert said is not None and _text(said) == "REFUSED"
        assert f"rcb replan {plan_id} --rcb alpha=VALUE" in _text(status)
        freed = eng.post(f"/plans/{plan_id}/replan", json={"rcb": {"alpha": 0.25}})
        assert freed.status_code == 201, freed.text
        assert eng.get(f"/plans/{plan_id}").json()["settings_refused"] is None
        report = report_at("SN-1", mes.get(f"/plans/{plan_id}/setpoints").json())
        again = mes.post(f"/plans/{plan_id}/parts", json=report, headers=key)
        assert again.status_code == 201, again.text  # the key held no answer: nothing stored
