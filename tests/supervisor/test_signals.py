"""Raw spindle readings in part reports: converted to force_N by the machine's calibration."""

from __future__ import annotations

import copy
import math
import tomllib

import pytest
from sqlalchemy import select
from sqlalchemy.orm import Session

from api.rest.schemas.parts import parse_report
from db import tables as t
from db.engine import make_engine
from models.errors import InputError
from models.sensors import ivester_load_V, to_force
from supervisor.inputs.plan import plan_from_mapping
from supervisor.inputs.signals import resolve
from supervisor.optimize.optimizer import optimize_plan

from conftest import DEMO_PLAN, renamed

PLAN = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
PLAN["machine"]["calibrations"] = {
    "spindle_load": {
        "kind": "ivester_spindle_load",
        "source": "Ivester & Heigel Eqs. 1-3, the NIST lathe",
        "idle_speeds_rpm": [300, 1200, 2400],
        "idle_loads_V": [0.20, 0.35, 0.55],
        "u_idle_load_V": 0.01,
    }
}
IDLE_V = 0.30  # measured idle load reported with the reading (overrides the table)


def _rough_od(setpoints):
    return next(op for op in setpoints["operations"] if op["name"] == "rough-od")


def _rpm(op):
    # n = 1000·v / (π·D), D = 60 mm (examples/ivester_demo_part.toml, rough-od)
    return 1000 * op["setpoint"]["speed_m_min"] / (math.pi * 60)


def _load_report(serial, setpoints, load_V, u_load_V):
    return {
        "serial": serial,
        "setpoint_version": setpoints["setpoint_version"],
        "operations": [
            {
                "name": "rough-od",
                "measurements": {
                    "spindle_load_V": {
                        "value": load_V,
                        "uncertainty": u_load_V,
                        "idle_load_V": IDLE_V,
                        "u_idle_load_V": 0.02,
                    },
                    "roughness_um": {"value": 2.5, "uncertainty": 0.05},
                },
            }
        ],
    }


def test_a_spindle_load_report_shrinks_the_band_exactly_as_its_force_would(server):
    with server.client("engineer") as c:
        a = c.post("/plans", json=renamed(PLAN), params={"strategy": "ivester"}).json()
        b = c.post("/plans", json=renamed(PLAN), params={"strategy": "ivester"}).json()
        op = _rough_od(a)
        assert _rpm(op) * 2 * math.pi / 60 > 70.2  # Eq. 2 side of the ratio (Ivester & Heigel)
        # a reading that corresponds to 95 % of the predicted force: inside the band, margin left
        force = 0.95 * op["predicted"]["force_N"]["value"]
        load_V = ivester_load_V(force, _rpm(op), 60.0, idle_load_V=IDLE_V)
        body = _load_report("L1", {"setpoint_version": 1, **a}, load_V, 0.02)
        r = c.post(f"/plans/{a['id']}/parts", json=body, headers={"Idempotency-Key": "sig-a"})
        assert r.status_code == 201, r.text
        by_load = {(u["operation"], u["quantity"]): u for u in r.json()["updates"]}

        converted = to_force(
            plan_from_mapping(PLAN).machine.calibrations["spindle_load"],
            "spindle_load_V",
            load_V,
            0.02,
            {
                "spindle_speed_rpm": _rpm(op),
                "workpiece_diameter_mm": 60.0,
                "idle_load_V": IDLE_V,
                "u_idle_load_V": 0.02,
            },
        )
        assert converted.value == pytest.approx(force, rel=1e-9)
        assert converted.uncertainty > 0
        same = copy.deepcopy(body)
        same["serial"] = "F1"
        same["operations"][0]["measurements"].pop("spindle_load_V")
        same["operations"][0]["measurements"]["force_N"] = {
            "value": converted.value,
            "uncertainty": converted.uncertainty,
        }
        r = c.post(f"/plans/{b['id']}/parts", json=same, headers={"Idempotency-Key": "sig-b"})
        assert r.status_code == 201, r.text
        by_force = {(u["operation"], u["quantity"]): u for u in r.json()["updates"]}

        key = ("rough-od", "force_N")
        assert by_load[key]["action"] == by_force[key]["action"] == "shrink"
        for field in ("margin", "band_before", "band_after", "measured"):
            assert by_load[key][field] == pytest.approx(by_force[key][field], rel=1e-12)
        assert r.json()["operations"] == c.get(f"/plans/{a['id']}/setpoints").json()["operations"]

        stored = c.get(f"/plans/{a['id']}/parts").json()["items"][0]["operations"][0]
        raw = stored["measurements"]["force_N"]["raw"]
        assert raw["quantity"] == "spindle_load_V" and raw["value"] == pytest.approx(load_V)
        assert raw["calibration"] == "spindle_load"
        assert raw["calibration_table"]["kind"] == "ivester_spindle_load"
        assert raw["context"]["spindle_speed_rpm"] == pytest.approx(_rpm(op))
    engine = make_engine(server.url)
    with Session(engine) as session:
        rows = session.scalars(
            select(t.Measurement).join(t.Part).where(t.Part.serial == "L1")
        ).all()
        assert {r.quantity for r in rows} == {"force_N", "roughness_um"}
    engine.dispose()


def test_bad_readings_are_refused_naming_the_field(server):
    with server.client("engineer") as c:
        plan = c.post("/plans", json=renamed(PLAN)).json()
        no_cal = {
            **PLAN,
            "machine": {k: v for k, v in PLAN["machine"].items() if k != "calibrations"},
        }
        bare = c.post("/plans", json={**no_cal, "name": "no-calibration"}).json()
        body = _load_report("B1", {"setpoint_version": 1, **plan}, 1.0, 0.02)
        cases = [
            (bare["id"], body, "operations[0].measurements.spindle_load_V", "no calibration"),
        ]
        named = copy.deepcopy(body)
        named["operations"][0]["measurements"]["spindle_load_V"]["calibration"] = "nope"
        cases.append(
            (
                plan["id"],
                named,
                "operations[0].measurements.spindle_load_V.calibration",
                "nope",
            )
        )
        twice = copy.deepcopy(body)
        twice["operations"][0]["measurements"]["force_N"] = {"value": 900, "uncertainty": 3}
        cases.append((plan["id"], twice, "operations[0].measurements.spindle_load_V", "twice"))
        below_idle = _load_report("B1", {"setpoint_version": 1, **plan}, 0.1, 0.02)
        cases.append((plan["id"], below_idle, "operations[0].measurements.spindle_load_V", "idle"))
        for i, (plan_id, report, field, _) in enumerate(cases):
            r = c.post(f"/plans/{plan_id}/parts", json=report, headers={"Idempotency-Key": f"b{i}"})
            assert r.status_code == 422, (field, r.text)
            assert r.json()["field"].startswith(field), r.json()
        assert c.get(f"/plans/{plan['id']}").json()["parts"] == 0  # nothing stored


def test_context_comes_from_the_setpoint_the_part_was_made_with():
    plan = plan_from_mapping(PLAN)
    result = optimize_plan(plan)
    op = next(o for o in result.operations if o.name == "rough-od")
    rpm = 1000 * op.setpoint["speed_m_min"] / (math.pi * 60)
    load_V = ivester_load_V(1500.0, rpm, 60.0, idle_load_V=IDLE_V)
    report = parse_report(
        _load_report("C1", {"setpoint_version": 1}, load_V, 0.02) | {"setpoint_version": 1}
    )
    measured, raw = resolve(report, plan, result)
    assert measured.measurements["rough-od"]["force_N"].value == pytest.approx(1500.0, rel=1e-9)
    assert not measured.signals
    context = raw[("rough-od", "force_N")]["context"]
    assert context["spindle_speed_rpm"] == pytest.approx(rpm, rel=1e-12)
    assert context["feed_rate_mm_min"] == pytest.approx(op.setpoint["feed_mm_rev"] * rpm)
    # a speed the MES measured overrides the setpoint's
    report = parse_report(
        {
            "serial": "C2",
            "setpoint_version": 1,
            "operations": [
                {
                    "name": "rough-od",
                    "measurements": {
                        "spindle_load_V": {
                            "value": load_V,
                            "uncertainty": 0.02,
                            "idle_load_V": IDLE_V,
                            "spindle_speed_rpm": rpm * 1.1,
                        }
                    },
                }
            ],
        }
    )
    measured, _ = resolve(report, plan, result)
    assert measured.measurements["rough-od"]["force_N"].value != pytest.approx(1500.0, rel=1e-3)


def test_a_bare_spindle_current_without_a_calibration_is_refused():
    plan = plan_from_mapping(PLAN)
    report = parse_report(
        {
            "serial": "I1",
            "setpoint_version": 1,
            "operations": [
                {
                    "name": "rough-od",
                    "measurements": {
                        "spindle_current_A": {"value": 4.0, "uncertainty": 0.05, "calibration": "x"}
                    },
                }
            ],
        }
    )
    with pytest.raises(InputError) as err:
        resolve(report, plan, optimize_plan(plan))
    assert err.value.field == "operations.rough-od.measurements.spindle_current_A.calibration"
