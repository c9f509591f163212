"""A plan whose stored structure fails this version's check is refused by name and repaired by
a replan (SQLite and PostgreSQL).

A release that tightens a check of the plan file (as migration 0025 did for ``z``) leaves stored
plans that fail it. Before, such a plan's part reports were 422 naming a plan-file field the
report never held (``operations[0].limits.force_N = -5.0``), and ``rcb replan PLAN --limit
rough-od.force_N=2000``, the repair, was refused on the stored value before the change applied:
only a hand-written migration freed the plan. Now the reports are 409
``stored_plan_refused`` naming the plan, the field and the replan that sets it anew; that
replan reads the plan with its change applied.
"""

from __future__ import annotations

import copy
from typing import Any

import pytest
from sqlalchemy import select, update
from sqlalchemy.orm import Session
from test_service import BODY
from typer.testing import CliRunner

from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan, replan
from api.services.read.plans import get_plan
from api.services.read.setpoints import current_setpoints
from api.services.read.tools import get_tool, list_tools
from db import library
from db import tables as t
from db.errors import ConflictError, StoredPlanError
from models.errors import InputError
from models.powerlaw import PowerLawModel
from models.tool import Tool

from conftest import engine_url, invoke, report_at


def _stored_with(engine, change, name: str = BODY["name"]) -> int:  # type: ignore[no-untyped-def]
    """A plan whose stored body ``change`` then altered in place (what an older check let by)."""
    plan_id = int(create_plan(engine=engine, body={**BODY, "name": name}).body["id"])
    with engine.begin() as c:
        body: dict[str, Any] = copy.deepcopy(
            c.execute(select(t.Plan.body).where(t.Plan.id == plan_id)).scalar_one()
        )
        change(body)
        c.execute(update(t.Plan).where(t.Plan.id == plan_id).values(body=body))
    return plan_id


def _report(engine, plan_id: int, serial: str):  # type: ignore[no-untyped-def]
    setpoints = current_setpoints(engine=engine, plan_id=plan_id)
    report = parse_report(report_at(serial, setpoints))
    return report_part(engine=engine, plan_id=plan_id, report=report)


def _negative_limit(body: dict[str, Any]) -> None:
    body["operations"][0]["limits"]["force_N"] = -5.0  # rough-od; a limit must be above 0


def test_a_refused_limit_names_the_repair_which_frees_the_plan(engine) -> None:
    plan_id = _stored_with(engine, _negative_limit)
    with pytest.raises(StoredPlanError) as refused:
        _report(engine, plan_id, "SN-1")
    assert (refused.value.field, refused.value.value) == ("operations[0].limits.force_N", -5.0)
    assert f"rcb replan {plan_id} --limit rough-od.force_N=VALUE" in str(refused.value)
    assert get_plan(engine=engine, plan_id=plan_id)["plan_refused"] == str(refused.value)
    shown = invoke(CliRunner(), "plans", "show", str(plan_id), "--db", engine_url(engine))
    told = " ".join(line.strip() for line in shown.stderr.splitlines())
    assert shown.exit_code == 0 and f"{BODY['name']} on lathe-22kW: REFUSED (below)" in told
    assert f"rcb replan {plan_id} --limit rough-od.force_N=VALUE" in told
    other = {"limits": {"rough-grooves.force_N": 2000}}  # changes another limit: still refused
    with pytest.raises(StoredPlanError, match="rough-od.force_N=VALUE"):
        replan(engine=engine, plan_id=plan_id, changes=other)
    with pytest.raises(InputError, match=r"force_N = -3: must be greater than 0"):  # its own error
        replan(engine=engine, plan_id=plan_id, changes={"limits": {"rough-od.force_N": -3}})
    repair = {"limits": {"rough-od.force_N": 2000}}
    assert replan(engine=engine, plan_id=plan_id, changes=repair, dry_run=True).status == 200
    with pytest.raises(StoredPlanError):  # a dry run stored nothing and cached nothing
        _report(engine, plan_id, "SN-1")
    assert replan(engine=engine, plan_id=plan_id, changes=repair).status == 201
    assert _report(engine, plan_id, "SN-1").status == 201  # it learns again
    with engine.connect() as c:
        newest = c.execute(
            select(t.PlanRevision.body).where(t.PlanRevision.plan_id == plan_id)
        ).scalar_one()
    assert newest["operations"][0]["limits"]["force_N"] == 2000
    assert get_plan(engine=engine, plan_id=plan_id)["plan_refused"] is None


def test_a_refused_bound_names_the_bound_and_a_field_no_replan_changes_says_so(engine) -> None:
    def swapped(body: dict[str, Any]) -> None:
        body["operations"][1]["bounds"]["feed_mm_rev"] = [0.3, 0.05]  # rough-grooves

    def unknown(body: dict[str, Any]) -> None:
        body["machine"]["power_kW"] = 22  # a field this version does not know

    bound = _stored_with(engine, swapped)
    with pytest.raises(StoredPlanError) as refused:
        _report(engine, bound, "SN-1")
    text = str(refused.value)
    assert f"rcb replan {bound} --bound rough-grooves.feed_mm_rev=LO:HI" in text
    assert '{"bounds": {"rough-grooves.feed_mm_rev": [LO, HI]}}' in text
    changes = {"bounds": {"rough-grooves.feed_mm_rev": [0.05, 0.4]}}
    assert replan(engine=engine, plan_id=bound, changes=changes).status == 201
    assert _report(engine, bound, "SN-1").status == 201
    machine = _stored_with(engine, unknown, "machine-field")
    with pytest.raises(StoredPlanError, match="a replan cannot change machine.power_kW"):
        _report(engine, machine, "SN-2")


def test_a_stored_tool_a_later_check_refuses_refuses_no_plan_that_does_not_use_it(engine) -> None:
    model = PowerLawModel("force_N", 1000.0, 100.0, {"feed_mm_rev": 0.8}, "test", "")
    with Session(engine) as session, session.begin():
        library.add_tool(session=session, tool=Tool("OLD-1", "turning", {"force_N": model}))
    with engine.begin() as c:  # what an older check let by: K must be above 0
        c.execute(update(t.ToolModel).values(K=-1.0).where(t.ToolModel.tool_id == _tool_id(c)))
    # before, every plan read every stored tool: this one refused every new plan
    assert create_plan(engine=engine, body=BODY).status == 201
    body = copy.deepcopy(BODY)
    body["name"], body["operations"][0]["tool"] = "uses-old-1", "OLD-1"
    with pytest.raises(ConflictError) as refused:  # the plan that names it: refused by name
        create_plan(engine=engine, body=body)
    assert (refused.value.field, refused.value.value) == ("tools.OLD-1.models.force_N.K", -1.0)
    assert "define it anew under another name" in str(refused.value)
    listed = {t["name"]: t for t in list_tools(engine=engine, page_size=500)["tools"]}
    assert listed["OLD-1"]["refused"] == str(refused.value)  # shown as stored, K = -1.0
    assert listed["OLD-1"]["models"]["force_N"]["K"] == -1.0
    assert listed["CNMG432RN"].get("refused") is None  # and every other tool beside it
    assert get_tool(engine=engine, name="OLD-1")["refused"] == str(refused.value)
    with engine.begin() as c:  # a process this version does not know: named the same way
        tool_id = _tool_id(c)
        c.execute(update(t.ToolModel).values(K=1000.0).where(t.ToolModel.tool_id == tool_id))
        c.execute(update(t.Tool).values(process="planing").where(t.Tool.id == tool_id))
    with Session(engine) as session, pytest.raises(ConflictError) as unknown:
        library.load_tools(session=session, names=["OLD-1"])
    assert (unknown.value.field, unknown.value.value) == ("tools.OLD-1.process", "planing")


def _tool_id(connection) -> int:  # type: ignore[no-untyped-def]
    return int(connection.execute(select(t.Tool.id).where(t.Tool.name == "OLD-1")).scalar_one())
