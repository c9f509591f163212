"""The notes implausible_low and regime_change, and a halt on a gross breach, on every surface.

The decisions are made by hand (issue 27: the rules that make them live in
supervisor/rcb/update.py): the real update runs and its decisions are rewritten before the
service stores them, so the part, its decisions and the halt go through the service and the
database as any part's do. Then a real ``rcb serve`` on that database answers REST and /ui,
the real ``rcb`` prints ``parts``, ``history`` and ``plans``, and the report page is rendered
from the stored record: each shows the two notes and the halt's message.
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import tomllib
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from rich.cells import cell_len
from typer.testing import CliRunner

from api.cli.main import app
from api.report import plots
from api.report.html import render_record
from api.report.series import operation_series
from api.rest.schemas.parts import PartCreated, parse_report
from api.services import parts as part_service
from api.services.parts import report_part
from api.services.plans import create_plan
from api.services.read import record
from db.engine import make_engine
from db.state_cache import CACHE
from supervisor.rcb.decision import Decision
from supervisor.rcb.state import Halt, HaltedOperation, RcbSettings, RcbState

from conftest import DEMO_PLAN, ROOT, renamed, report_at, stored_state
from live import RCB, LiveServer
from migrated import migrated

PLAN = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
#: The halt the gross-breach rule hands over (issue 27): no conflicts, the reading named.
GROSS = (
    "rough-od force_N measured 6000 N is past its limit 2000 N by 200 % (more than halt_over "
    "25 %): an engineer must check the process and replan"
)
CHECK = "CHECK SENSOR: implausibly low"
REGIME = "note: regime change"
ABOVE_REGIME = "ABOVE, regime change"

Rewrite = Callable[[RcbState, RcbState, list[Decision]], tuple[RcbState, list[Decision]]]


def _only(decisions: list[Decision], operation: str, quantity: str, **changes: Any):
    """``decisions`` with the one of ``operation`` and ``quantity`` changed."""
    return [
        dataclasses.replace(d, **changes)
        if (d.operation, d.quantity) == (operation, quantity)
        else d
        for d in decisions
    ]


def _implausible(before, after, decisions):
    """rough-od force_N quarantined: no shrink, a note for the operator."""
    held = {"action": "hold", "flag": None, "flagged": False, "note": "implausible_low"}
    return after, _only(decisions, "rough-od", "force_N", **held)


def _regime(before, after, decisions):
    """A new regime: rough-od force_N past the band (a flag), finish roughness a note."""
    flagged = {"action": "expand", "flag": "above_band", "flagged": True, "note": "regime_change"}
    changed = _only(decisions, "rough-od", "force_N", **flagged)
    second = PLAN["operations"][1]["name"]
    return after, _only(changed, second, "roughness_um", note="regime_change")


def _gross(before, after, decisions):
    """A breach past halt_over: the plan halts on the setpoints the part was made with."""
    halt = Halt((HaltedOperation("rough-od", (), (), GROSS),))
    breach = {"action": "expand", "flag": "breach", "flagged": True, "note": None}
    halted = dataclasses.replace(after, setpoints=before.setpoints, version=before.version)
    return dataclasses.replace(halted, halt=halt), _only(decisions, "rough-od", "force_N", **breach)


def _stored_plan(url: str) -> dict[str, Any]:
    """A plan with three parts: an implausible_low, a regime_change, a gross-breach halt."""
    migrated(url)
    engine = make_engine(url)
    try:
        created = create_plan(engine=engine, body=PLAN, settings=RcbSettings("ivester")).body
        plan_id, setpoints = created["id"], created
        answers: dict[str, dict[str, Any]] = {}
        real = part_service.update
        rewrite: list[Rewrite] = []

        def rewritten(state, *args, **kwargs):
            after, decisions = real(state, *args, **kwargs)
            return rewrite[-1](state, after, list(decisions))

        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(part_service, "update", rewritten)
            for serial, change in (("SN-LOW", _implausible), ("SN-REGIME", _regime)):
                rewrite.append(change)
                answers[serial] = report_part(
                    engine=engine,
                    plan_id=plan_id,
                    report=parse_report(report_at(serial, setpoints)),
                ).body
                setpoints = answers[serial]
            rewrite.append(_gross)
            body = report_at("SN-GROSS", setpoints)
            rough = next(o for o in body["operations"] if o["name"] == "rough-od")
            rough["measurements"]["force_N"] = {"value": 6000.0, "uncertainty": 10.0}
            answers["SN-GROSS"] = report_part(
                engine=engine, plan_id=plan_id, report=parse_report(body)
            ).body
        state = stored_state(engine, plan_id)
        shown = record.report_record(engine=engine, plan_id=plan_id, last=100)
        page = render_record(shown)
    finally:
        CACHE.clear()
        engine.dispose()
    return {
        "url": url,
        "plan_id": plan_id,
        "answers": answers,
        "state": state,
        "page": page,
        "record": shown,
    }


@pytest.fixture(scope="module", params=["sqlite", "postgres"])
def stored(request, tmp_path_factory) -> Iterator[dict[str, Any]]:
    """The plan of :func:`_stored_plan` on each backend, and a real server on its database."""
    if request.param == "sqlite":
        url = f"sqlite:///{tmp_path_factory.mktemp('notes') / 'rcb.db'}"
    else:
        url = request.getfixturevalue("module_postgres")
    data = _stored_plan(url)
    live = LiveServer(url, tmp_path_factory.mktemp("log") / "serve.log")
    live.start()
    try:
        yield data | {"server": live}
    finally:
        live.stop()


def _update(updates: list[dict[str, Any]], operation: str, quantity: str) -> dict[str, Any]:
    (found,) = [u for u in updates if (u["operation"], u["quantity"]) == (operation, quantity)]
    return found


def test_the_halt_is_stored_and_read_back(stored):
    halt = stored["state"].halt
    assert halt == Halt((HaltedOperation("rough-od", (), (), GROSS),))
    assert halt.message == GROSS
    assert stored["state"].settings.halt_over == 0.25


def test_the_201_answer_says_halted_and_names_the_reading(stored):
    answer = stored["answers"]["SN-GROSS"]
    PartCreated.model_validate(answer)  # the REST schema takes it
    assert answer["halted"] is True
    assert answer["conflicts"] == [
        {"operation": "rough-od", "message": GROSS, "conflicts": [], "held_by": []}
    ]
    assert _update(answer["updates"], "rough-od", "force_N")["flag"] == "breach"
    low = _update(stored["answers"]["SN-LOW"]["updates"], "rough-od", "force_N")
    assert (low["note"], low["flag"], low["flagged"]) == ("implausible_low", None, False)


def test_rest_shows_the_notes_and_the_halt(stored):
    plan_id = stored["plan_id"]
    with stored["server"].client("viewer") as c:
        items = c.get(f"/plans/{plan_id}/parts").json()["items"]
        by_serial = {p["serial"]: p for p in items}
        low = _update(by_serial["SN-LOW"]["updates"], "rough-od", "force_N")
        assert (low["note"], low["flag"], low["flagged"]) == ("implausible_low", None, False)
        regime = by_serial["SN-REGIME"]["updates"]
        above = _update(regime, "rough-od", "force_N")
        assert (above["flag"], above["note"]) == ("above_band", "regime_change")
        second = PLAN["operations"][1]["name"]
        assert _update(regime, second, "roughness_um")["note"] == "regime_change"

        detail = c.get(f"/plans/{plan_id}").json()
        assert detail["status"] == "halted" and detail["settings"]["halt_over"] == 0.25
        assert detail["halt"]["message"] == GROSS
        assert detail["halt"]["conflicts"] == stored["answers"]["SN-GROSS"]["conflicts"]
        history = c.get(f"/plans/{plan_id}/history").json()
        assert history["status"] == "halted" and history["halt"] == detail["halt"]
        listed = {p["id"]: p for p in c.get("/plans").json()["plans"]}
        assert listed[plan_id]["halt"]["message"] == GROSS

        refused = c.get(f"/plans/{plan_id}/setpoints")
        assert refused.status_code == 409
        assert refused.headers["content-type"].startswith("application/problem+json")
        problem = refused.json()
        assert problem["code"] == "plan_halted" and GROSS in problem["detail"]
        assert problem["conflicts"] == detail["halt"]["conflicts"]


@pytest.mark.parametrize(
    ("value", "status"), [("0.75", 201), ("0", 422), ("-1", 422), ("10.5", 422), ("nan", 422)]
)
def test_post_plans_takes_halt_over_and_refuses_a_bad_one_naming_it(stored, value, status):
    with stored["server"].client("engineer") as c:
        answer = c.post(
            "/plans", params={"strategy": "ivester", "halt_over": value}, json=renamed(PLAN)
        )
        assert answer.status_code == status, answer.text
        if status == 201:
            settings = c.get(f"/plans/{answer.json()['id']}").json()["settings"]
            assert settings["halt_over"] == float(value)
            return
    assert answer.headers["content-type"].startswith("application/problem+json")
    problem = answer.json()
    assert problem["field"] == "halt_over" and problem["status"] == 422


def _rcb(*args: str, columns: int) -> str:
    env = {**os.environ, "COLUMNS": str(columns)}
    done = subprocess.run(
        [str(RCB), *args], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


def _fits(stdout: str, columns: int) -> None:
    for line in stdout.splitlines():
        assert cell_len(line) <= columns, line
        assert "…" not in line, line


@pytest.mark.parametrize("command", ["parts", "history"])
def test_cli_tables_show_the_notes_and_fit_80_columns(stored, command):
    plan = str(stored["plan_id"])
    wide = _rcb(command, plan, "--db", stored["url"], columns=250)
    assert CHECK in wide and REGIME in wide and ABOVE_REGIME in wide
    narrow = _rcb(command, plan, "--db", stored["url"], columns=80)
    _fits(narrow, 80)
    words = narrow.split()
    for word in ("CHECK", "SENSOR:", "implausibly", "regime"):
        assert word in words, word


def _rcb_json(*args: str) -> Any:
    """``rcb ... --json`` in this process: the document, not the terminal (run for real
    above and below), is what is checked."""
    done = CliRunner().invoke(app, [*args, "--json"])
    assert done.exit_code == 0, done.output
    return json.loads(done.stdout)


def test_cli_history_json_and_plans_show_the_notes_and_the_halt(stored):
    plan = str(stored["plan_id"])
    data = _rcb_json("history", plan, "--db", stored["url"])
    notes = {d["note"] for v in data["versions"] for d in v["decisions"]}
    assert {"implausible_low", "regime_change"} <= notes
    assert data["halt"]["message"] == GROSS
    listed = _rcb_json("plans", "--db", stored["url"])["plans"]
    assert listed[0]["settings"]["halt_over"] == 0.25 and listed[0]["halt"]["message"] == GROSS
    for command in (["history", plan], ["plans"]):
        shown = _rcb(*command, "--db", stored["url"], columns=250)
        assert "a reading is past its limit by more than the plan's halt_over" in shown
        assert GROSS in shown
        assert "no setpoint meets" not in shown
        _fits(_rcb(*command, "--db", stored["url"], columns=80), 80)


def _xml(page: str) -> ET.Element:
    return ET.fromstring(page.removeprefix("<!DOCTYPE html>\n"))


def _text(element: ET.Element) -> str:
    return "".join(element.itertext()).strip()


def _check_page(page: str) -> None:
    """The report page (and /ui's): the marks with their classes, the halt's message."""
    root = _xml(page)
    spans = {(s.get("class"), _text(s)) for s in root.iter("span")}
    assert ("check", CHECK) in spans
    assert ("note", REGIME) in spans
    assert ("above-band", ABOVE_REGIME) in spans
    rows = [r for r in root.iter("tr") if CHECK in _text(r)]
    assert any("check" in (r.get("class") or "").split() for r in rows)
    assert "span.check" in page and "tr.check td" in page  # the CSS that makes it stand out
    overview = {_text(dt): dd for dt, dd in zip(root.iter("dt"), root.iter("dd"), strict=True)}
    (count,) = overview["CHECK SENSOR: implausibly low readings"].iter("span")
    assert count.get("class") == "check" and _text(count).startswith("1:")
    (halt,) = [s for s in root.iter("section") if s.get("class") == "halt"]
    assert GROSS in [_text(li) for li in halt.iter("li")]
    assert "A reading is past its limit by more than the plan's halt_over" in _text(halt)
    assert "No setpoint meets" not in _text(halt)


def test_the_report_shows_the_notes_and_the_halt(stored):
    _check_page(stored["page"])


def test_the_outputs_plot_marks_the_implausible_reading_apart(stored):
    shown = stored["record"]
    series = operation_series(shown["plan"], shown["history"], shown["parts"], "rough-od")
    force = next(o for o in series.outputs if o.quantity == "force_N")
    assert force.checked.tolist() == [True, False, False, False]  # SN-LOW, not the next part
    assert force.flagged.tolist() == [False, True, True, False]  # ABOVE, BREACH
    figure = plots.outputs_figure(series)
    labels = {mark.label: mark for mark in figure.panels[0].marks}
    assert list(labels["check sensor: implausibly low"].x) == [1]  # part number


def test_the_plots_draw_the_change_of_the_process_where_it_was_seen(stored):
    """A rule at each part whose reading saw the process change, on the readings' and the
    bands' panels of that quantity alone (was only in the tables): SN-REGIME (part 2) for
    the two it was written on, and wherever the real update saw one."""
    shown = stored["record"]
    changed = {
        (u["operation"], u["quantity"], number)
        for number, part in enumerate(shown["parts"], start=1)
        for u in part["updates"]
        if u.get("note") == "regime_change"
    }
    second = PLAN["operations"][1]["name"]
    assert {("rough-od", "force_N", 2), (second, "roughness_um", 2)} <= changed
    drawn = set()
    for operation in {o["name"] for o in PLAN["operations"]}:
        series = operation_series(shown["plan"], shown["history"], shown["parts"], operation)
        for figure in (plots.outputs_figure(series), plots.bands_figure(series)):
            for output, panel in zip(series.outputs, figure.panels, strict=True):
                for rule in (m for m in panel.marks if m.kind == "vlines"):
                    assert rule.label == plots.CHANGED
                    drawn |= {(operation, output.quantity, int(x)) for x in rule.x}
    assert drawn == changed
    assert f'stroke="{plots.CHANGE}"' in stored["page"]


def test_the_web_view_shows_the_notes_and_the_halt(stored):
    live = stored["server"]
    base = f"http://127.0.0.1:{live.port}/ui"
    with httpx.Client(base_url=base, timeout=60.0) as browser:
        assert browser.post("/login", data={"key": live.keys["viewer"]}).status_code == 303
        listed = browser.get("/")
        assert listed.status_code == 200 and "HALTED" in listed.text
        page = browser.get(f"/plans/{stored['plan_id']}")
        assert page.status_code == 200
    _check_page(page.text)


def test_the_report_cli_writes_the_same_marks(stored, tmp_path: Path):
    out = tmp_path / "report.html"
    _rcb("report", str(stored["plan_id"]), "--db", stored["url"], "--out", str(out), columns=80)
    _check_page(out.read_text(encoding="utf-8"))
