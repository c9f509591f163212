"""A part's RCB decisions read back as its report answered them, ``predicted`` and ``measured``
included (alembic 0029).

Through the services on a real database: the demo plan with force and roughness readings made
on a virtual lathe, and examples/virtual_lathe_part.toml with spindle-load readings, whose
``measured`` is the force converted from the reading (the value the decision judged, not the
volts). Each part's ``updates`` in the 201 answer are compared field for field with the page of
parts (``GET /plans/{id}/parts``, ``rcb parts --json``, ``rcb export``), with the report's
newest decision per operation and quantity, and with the export's decisions table.
"""

from __future__ import annotations

import math
import tomllib
from typing import Any

from sqlalchemy import Engine
from test_service import BODY, _reports

from api.report import export as tidy
from api.rest.schemas.parts import parse_report
from api.services import read as queries
from api.services.parts import report_part
from api.services.plans import create_plan
from models.sensors import ivester_load_V
from supervisor.rcb.state import RcbSettings

from conftest import ROOT

LATHE = tomllib.loads((ROOT / "examples" / "virtual_lathe_part.toml").read_text(encoding="utf-8"))
#: Each part's spindle load as a share of the predicted force: below it, at it, past it (flags),
#: and back.
SHARES = (0.92, 0.97, 1.0, 1.06, 0.95)
IDLE_V = 0.30  # the idle load reported with each reading (Ivester & Heigel Eq. 3)


def _load_report(serial: str, answer: dict[str, Any], share: float) -> dict[str, Any]:
    """Spindle-load readings of every operation at ``share`` of its predicted force."""
    diameters = {op["name"]: op["workpiece_diameter_mm"] for op in LATHE["operations"]}
    operations = []
    for op in answer["operations"]:
        diameter = diameters[op["name"]]
        rpm = 1000 * op["setpoint"]["speed_m_min"] / (math.pi * diameter)  # n = 1000 v / (π D)
        force = share * op["predicted"]["force_N"]["value"]
        load_V = ivester_load_V(force, rpm, diameter, idle_load_V=IDLE_V)
        reading = {"value": load_V, "uncertainty": 0.02, "idle_load_V": IDLE_V}
        operations.append({"name": op["name"], "measurements": {"spindle_load_V": reading}})
    return {
        "serial": serial,
        "setpoint_version": answer["setpoint_version"],
        "operations": operations,
    }


def _report_all(engine: Engine, plan_id: int, bodies: list[dict[str, Any]]) -> list[dict]:
    return [
        report_part(engine=engine, plan_id=plan_id, report=parse_report(b)).body for b in bodies
    ]


def _assert_read_back(engine: Engine, plan_id: int, answers: list[dict[str, Any]]) -> None:
    """Every surface that reads a stored decision shows what the 201 answer showed."""
    read = queries.all_parts(engine=engine, plan_id=plan_id)
    assert [p["serial"] for p in read] == [a["serial"] for a in answers]
    for part, answer in zip(read, answers, strict=True):
        assert answer["updates"], answer["serial"]
        assert part["updates"] == answer["updates"], answer["serial"]
        for u in part["updates"]:
            assert u["predicted"] is not None and u["measured"] is not None
    newest = {(u["operation"], u["quantity"]): u for a in answers for u in a["updates"]}
    record = queries.report_record(engine=engine, plan_id=plan_id)
    latest = record["last_decisions"]
    assert {(d["operation"], d["quantity"]): d for d in latest} == {
        key: {**u, "serial": answers[-1]["serial"]} for key, u in newest.items()
    }
    frame = tidy.part_frames(plan_id, read)["decisions"]
    answered = [u for a in answers for u in a["updates"]]
    for column in ("predicted", "measured"):
        assert frame[column].tolist() == [u[column] for u in answered]


def test_force_readings_read_back_as_answered(engine):
    bayes = RcbSettings("bayes")
    plan_id = create_plan(engine=engine, body=BODY, settings=bayes).body["id"]
    bodies, _ = _reports(4, settings=bayes)
    _assert_read_back(engine, plan_id, _report_all(engine, plan_id, bodies))


def test_spindle_load_readings_read_back_as_the_force_judged(engine):
    answer = create_plan(engine=engine, body=LATHE, settings=RcbSettings("ivester")).body
    plan_id, answers = answer["id"], []
    for i, share in enumerate(SHARES):
        body = _load_report(f"L-{i + 1}", answer, share)
        answer = _report_all(engine, plan_id, [body])[0]
        answers.append(answer)
        volts = [op["measurements"]["spindle_load_V"]["value"] for op in body["operations"]]
        judged = [u["measured"] for u in answer["updates"] if u["quantity"] == "force_N"]
        assert len(judged) == len(volts) and not set(judged) & set(volts)  # forces, not volts
    _assert_read_back(engine, plan_id, answers)
    for part in queries.all_parts(engine=engine, plan_id=plan_id):
        stored = {op["name"]: op["measurements"]["force_N"] for op in part["operations"]}
        for u in part["updates"]:  # the value judged is the converted force the part stored
            assert stored[u["operation"]]["raw"]["quantity"] == "spindle_load_V"
            assert u["measured"] == stored[u["operation"]]["value"]
