"""Milling through the whole loop over REST: a real uvicorn process, SQLite and PostgreSQL.

The milling demonstration plan (examples/milling_demo_part.toml) is created over REST; a part
report gives the slot's force as a spindle current reading (Kim & Jeon §6.2.3, converted by the
machine's calibration at the setpoint's feed rate) and a second plan constrains the spindle
current itself, which RCB shrinks like any model quantity.
"""

from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path

import pytest

from models.sensors import to_force
from supervisor.inputs.plan import plan_from_mapping

PLAN_FILE = Path(__file__).resolve().parents[2] / "examples" / "milling_demo_part.toml"
PLAN = tomllib.loads(PLAN_FILE.read_text())


def _op(body, name):
    return next(op for op in body["operations"] if op["name"] == name)


def _feed_rate(op):
    # vf = fz · z · n, n = 1000 v / (π D): Ø10 mm, two flutes (examples/milling_demo_part.toml)
    s = op["setpoint"]
    return s["feed_per_tooth_mm"] * 2 * 1000 * s["speed_m_min"] / (math.pi * 10)


def test_milling_plan_and_current_report(server):
    with server.client("engineer") as c:
        r = c.post("/plans", json=PLAN, params={"strategy": "ivester"})
        assert r.status_code == 201, r.text
        created = r.json()
        slot = _op(created, "slot")
        assert set(slot["setpoint"]) == {
            "axial_depth_mm",
            "radial_depth_mm",
            "feed_per_tooth_mm",
            "speed_m_min",
        }
        assert "force_N" in slot["binding"]
        force = slot["predicted"]["force_N"]
        # on the 230 N limit at the continuous optimum (ap 2.14140); at the grid point ap
        # 2.141 mm just under it: (26.61 + 6.65) · 2.141 · 10^1.432 · 0.047^0.695 = 229.957 N
        assert slot["setpoint"]["axial_depth_mm"] == 2.141
        assert force["value"] + force["band"] == pytest.approx(229.957, abs=1e-3)

        current_A, u_A = 4.35, 0.02
        body = {
            "serial": "M1",
            "setpoint_version": 1,
            "operations": [
                {
                    "name": "slot",
                    "measurements": {
                        "spindle_current_A": {"value": current_A, "uncertainty": u_A},
                        "roughness_um": {"value": 1.0, "uncertainty": 0.05},
                    },
                },
                {
                    "name": "side-finish",
                    "measurements": {"roughness_um": {"value": 0.7, "uncertainty": 0.05}},
                },
            ],
        }
        r = c.post(f"/plans/{created['id']}/parts", json=body, headers={"Idempotency-Key": "m1"})
        assert r.status_code == 201, r.text
        updates = {(u["operation"], u["quantity"]): u for u in r.json()["updates"]}

    calibration = plan_from_mapping(PLAN).machine.calibrations["spindle_current"]
    rpm = 1000 * slot["setpoint"]["speed_m_min"] / (math.pi * 10)
    context = {"spindle_speed_rpm": rpm, "feed_rate_mm_min": _feed_rate(slot)}
    expected = to_force(calibration, "spindle_current_A", current_A, u_A, context)
    update = updates[("slot", "force_N")]
    assert update["measured"] == pytest.approx(expected.value, rel=1e-12)
    # margin = limit − (measured + u) with the conversion's uncertainty (DESIGN.md, RCB), the
    # reading over its prediction by δ counting u + δ up to Q u, Q = 3.1458193 (the chain's
    # bound scale) before any reading has shown the chain's noise (supervisor.rcb.law)
    over = expected.value - force["value"]
    assert over > 0
    extra = min(over, (3.1458193 - 1.0) * expected.uncertainty)
    assert update["margin"] == pytest.approx(
        230.0 - expected.value - expected.uncertainty - extra, rel=1e-7
    )
    assert update["action"] == "shrink"
    assert update["band_after"] == pytest.approx(update["band_before"] - 0.25 * update["margin"])


def _current_plan():
    plan = copy.deepcopy(PLAN)
    plan["name"] = "milling-current-limit"
    del plan["machine"]["calibrations"]
    plan["tools"][0]["name"] = "EM10-2F-with-current"  # a tool's name keeps its models
    # Tai et al. §III.A: the spindle current itself is the limit (I_ref = 0.85 × 0.28 A);
    # a power law of the current over the side pass, band 10 % (chosen for the test)
    plan["tools"][0]["models"]["spindle_current_A"] = {
        "K": 2.0,
        "dK": 0.2,
        "exponents": {"axial_depth_mm": 0.3, "feed_per_tooth_mm": 0.2},
    }
    side = next(op for op in plan["operations"] if op["name"] == "side-finish")
    side["tool"] = "EM10-2F-with-current"
    side["limits"] = {"spindle_current_A": 1.6, "roughness_um": 1.0}
    plan["operations"] = [side]
    return plan


def test_spindle_current_is_a_limit_rcb_shrinks(server):
    with server.client("engineer") as c:
        r = c.post("/plans", json=_current_plan(), params={"strategy": "ivester"})
        assert r.status_code == 201, r.text
        created = r.json()
        side = _op(created, "side-finish")
        current = side["predicted"]["spindle_current_A"]
        assert current["value"] + current["band"] <= 1.6 * (1 + 1e-6)
        body = {
            "serial": "C1",
            "setpoint_version": 1,
            "operations": [
                {
                    "name": "side-finish",
                    "measurements": {
                        "spindle_current_A": {"value": current["value"], "uncertainty": 0.01}
                    },
                }
            ],
        }
        r = c.post(f"/plans/{created['id']}/parts", json=body, headers={"Idempotency-Key": "c1"})
        assert r.status_code == 201, r.text
        update = next(u for u in r.json()["updates"] if u["quantity"] == "spindle_current_A")
        margin = 1.6 - current["value"] - 0.01
        assert update["action"] == "shrink"
        assert update["margin"] == pytest.approx(margin, rel=1e-9)
        assert update["band_before"] == pytest.approx(current["band"], rel=1e-9)
        assert update["band_after"] == pytest.approx(current["band"] - 0.25 * margin, rel=1e-9)
        after = _op(r.json(), "side-finish")
        assert after["mrr_cm3_min"] >= side["mrr_cm3_min"]
