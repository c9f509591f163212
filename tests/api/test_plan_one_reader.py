"""A plan over REST is read by the plan reader alone (issue 31, item 3): every error at once.

``rcb serve`` as a real process on SQLite and PostgreSQL; the same file at the command line
gives the same errors, one line each; a JSON null of an optional field is the field left out
and the plan is stored without it; a refused plan's audit entry keeps what no column can hold
escaped.
"""

from __future__ import annotations

import copy
import json

from sqlalchemy import select
from sqlalchemy.orm import Session

from api.cli.main import app
from db import tables as t
from db.engine import make_engine

from conftest import step1_plan


def _two_wrong_operations() -> dict:
    plan = step1_plan()
    second = copy.deepcopy(plan["operations"][0])
    second["name"], second["volume_mm3"] = "finish-od", 0
    plan["operations"][0]["bounds"]["feed_mm_rev"] = [0.6, 0.1]
    plan["operations"].append(second)
    return plan


def test_every_error_of_a_plan_comes_at_once_over_rest_and_at_the_cli(server, runner, tmp_path):
    plan = _two_wrong_operations()
    with server.client("engineer") as c:
        refused = c.post("/plans", json=plan)
    assert refused.status_code == 422, refused.text
    assert refused.headers["content-type"] == "application/problem+json"
    problem = refused.json()
    assert [(e["field"], e["value"]) for e in problem["errors"]] == [
        ("operations[0].bounds.feed_mm_rev", [0.6, 0.1]),
        ("operations[1].volume_mm3", 0),
    ]
    assert (problem["field"], problem["code"]) == ("operations[0].bounds.feed_mm_rev", "invalid")
    assert problem["detail"].startswith("2 errors; the first: operations[0].bounds.feed_mm_rev")
    assert problem["errors"][1]["message"] == "must be greater than 0"
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(plan), encoding="utf-8")
    result = runner.invoke(app, ["plans", "create", str(path), "--db", server.url])
    assert result.exit_code == 2, result.output
    assert result.stderr.splitlines() == [
        "rcb: error: operations[0].bounds.feed_mm_rev = [0.6, 0.1]: low 0.6 is above high 0.1",
        "rcb: error: operations[1].volume_mm3 = 0: must be greater than 0",
    ]


def test_the_rcb_table_s_errors_come_with_the_plan_s(server, runner, tmp_path):
    plan = step1_plan()
    plan["rcb"] = {"alpha": 2}
    plan["operations"][0]["volume_mm3"] = "lots"
    with server.client("engineer") as c:
        refused = c.post("/plans", json=plan)
    assert refused.status_code == 422, refused.text
    assert [(e["field"], e["value"]) for e in refused.json()["errors"]] == [
        ("rcb.alpha", 2),
        ("operations[0].volume_mm3", "lots"),
    ]
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(plan), encoding="utf-8")
    result = runner.invoke(app, ["plans", "create", str(path), "--db", server.url])
    assert result.exit_code == 2, result.output
    lines = result.stderr.splitlines()
    assert [line.split(" = ")[0] for line in lines] == [
        "rcb: error: rcb.alpha",
        "rcb: error: operations[0].volume_mm3",
    ]


def test_a_null_optional_field_is_left_out_and_stored_so(server):
    plan = step1_plan()
    plan.update(name="nulls", description=None, tools=None, rcb=None)
    plan["machine"]["calibrations"] = None
    plan["operations"][0].update(catalog_setpoint=None, stock_mm=None, finish=None)
    with server.client("engineer") as c:
        created = c.post("/plans", json=plan)
        assert created.status_code == 201, created.text
        stored = c.get(f"/plans/{created.json()['id']}").json()["body"]
        plan["operations"][0]["limits"]["force_N"] = None
        refused = c.post("/plans", json={**plan, "name": "null-limit"})
    assert stored == {**step1_plan(), "name": "nulls"}
    assert refused.status_code == 422, refused.text
    assert (refused.json()["field"], refused.json()["value"]) == (
        "operations[0].limits.force_N",
        None,
    )


def test_a_plan_stored_as_sent_is_replanned_by_its_names_as_read(server):
    """The body keeps the spelling sent (``'rough-od '``); a replan names the operation as read."""
    plan = {**step1_plan(), "name": "spelt"}
    plan["operations"][0]["name"] = "rough-od "
    with server.client("engineer") as c:
        created = c.post("/plans", json=plan)
        assert created.status_code == 201, created.text
        plan_id = created.json()["id"]
        assert [o["name"] for o in created.json()["operations"]] == ["rough-od"]
        changed = c.post(
            f"/plans/{plan_id}/replan", json={"limits": {"ｒｏｕｇｈ-ｏｄ.force_N": 1800}}
        )
        stored = c.get(f"/plans/{plan_id}").json()["body"]
    assert changed.status_code == 201, changed.text
    assert stored["operations"][0]["name"] == "rough-od "
    assert stored["operations"][0]["limits"]["force_N"] == 1800


def test_a_refused_plan_s_audit_entry_keeps_unstorable_text_escaped(server):
    plan = {**step1_plan(), "name": "bad\ud800name"}
    plan["operations"][0]["limits"]["bad\x00key"] = 1
    with server.client("engineer") as c:
        refused = c.post(
            "/plans", content=json.dumps(plan), headers={"Content-Type": "application/json"}
        )
    assert refused.status_code == 422, refused.text
    assert [e["field"] for e in refused.json()["errors"]] == [
        "name",
        "operations[0].limits.bad\x00key",
    ]
    engine = make_engine(server.url)
    try:
        with Session(engine) as session:
            entry = session.scalars(
                select(t.AuditEntry)
                .where(t.AuditEntry.result == "refused")
                .order_by(t.AuditEntry.id.desc())
                .limit(1)  # fmt: skip
            ).one()
    finally:
        engine.dispose()
    assert entry.target == "plan bad\\ud800name"
    assert entry.detail["field"] == "name"
    assert entry.detail["error"] == "InputErrors"


def test_a_replan_is_read_by_the_replan_alone_nulls_as_no_change(server):
    """``ReplanIn`` documents the changes; ``supervisor.rcb.replan`` reads them."""
    with server.client("engineer") as c:
        created = c.post("/plans", json={**step1_plan(), "name": "replanned"})
        assert created.status_code == 201, created.text
        url = f"/plans/{created.json()['id']}/replan"
        bad = c.post(url, json={"limits": {"rough-od.force_N": "abc"}})
        unknown = c.post(url, json={"limits": {"rough-od.force_N": 1800}, "reset": True})
        changed = c.post(url, json={"limits": {"rough-od.roughness_um": None,
                                               "rough-od.force_N": 1800},
                                    "reset_bands": None, "models": None,
                                    "rcb": {"alpha": None}})  # fmt: skip
        stored = c.get(f"/plans/{created.json()['id']}").json()
    assert bad.status_code == 422, bad.text
    # the change's path in the request, not the plan's (operations[0].limits.force_N)
    assert (bad.json()["field"], bad.json()["value"]) == ("limits.rough-od.force_N", "abc")
    assert unknown.status_code == 422, unknown.text
    assert (unknown.json()["field"], unknown.json()["value"]) == ("reset", True)
    assert changed.status_code == 201, changed.text
    assert stored["body"]["operations"][0]["limits"] == {"force_N": 1800}
    assert stored["alpha"] == 0.25  # a null setting changes nothing
