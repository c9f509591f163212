"""Constant-load milling through the whole loop over REST (a real uvicorn process).

examples/tai_constant_load_part.toml: each milling setpoint carries Tai et al.'s reference
current and feed limits; RCB on the spindle current raises the programmed feed and the upper
limit with it, up to Eq. 13's; a reported feed override at the lower limit calls for a tool
change (Tai et al. §III.C), stored with the part.
"""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PLAN = tomllib.loads((ROOT / "examples" / "tai_constant_load_part.toml").read_text())
MILLING = tomllib.loads((ROOT / "examples" / "milling_demo_part.toml").read_text())

# Tai et al. §III.A end-milling plane (examples/tai_constant_load_part.toml)
A, B, K1, S = 0.11584, 1.2416e-4, 0.22263, 0.002
I_REF = 0.85 * 0.28  # 0.238 A
# Eq. 13 at the reference current: (0.238 − 0.11584) / 1.2416e-4 = 983.89 mm/min
UPPER = (I_REF - A) / B
# Eq. 15 at the worn end, 220 µm, raised by its k = 2 band 2·s/B: 589.41 + 32.22 = 621.63
LOWER = (I_REF - A - K1 * 0.220) / B + 2 * S / B


def _op(body, name):
    return next(op for op in body["operations"] if op["name"] == name)


def _named(plan, name):
    plan = copy.deepcopy(plan)
    plan["name"] = name
    return plan


def _report(serial, version, current_A, override=None):
    """``current_A``: one reading for both operations, or a mapping per operation."""
    ops = []
    for name in ("slot", "end-mill"):
        value = current_A[name] if isinstance(current_A, dict) else current_A
        entry = {
            "name": name,
            "measurements": {"spindle_current_A": {"value": value, "uncertainty": 0.002}},
        }
        if override is not None:
            entry["feed_override_percent"] = override
        ops.append(entry)
    return {"serial": serial, "setpoint_version": version, "operations": ops}


def test_setpoints_carry_the_reference_current_and_feed_limits(server):
    assert UPPER == pytest.approx(983.89, abs=0.01) and LOWER == pytest.approx(621.63, abs=0.01)
    with server.client("engineer") as c:
        r = c.post("/plans", json=_named(PLAN, "cl-limits"))
        assert r.status_code == 201, r.text
        created = r.json()
        end = _op(created, "end-mill")
        cl = end["constant_load"]
        assert cl["reference_current_A"] == pytest.approx(I_REF, rel=1e-12)
        assert cl["feed_rate_lower_mm_min"] == pytest.approx(LOWER, rel=1e-9)
        # the robust optimum feeds below Eq. 13's limit: the upper limit is the programmed feed
        programmed = cl["programmed_feed_rate_mm_min"]
        assert programmed == pytest.approx(end["predicted"]["feed_rate_mm_min"]["value"])
        assert cl["upper_governed_by"] == "setpoint" and programmed < UPPER
        assert cl["feed_rate_upper_mm_min"] == pytest.approx(programmed, rel=1e-12)
        assert cl["tool_change_by_feed"] is True and cl["wear_interval_mm"] == [0.18, 0.22]
        # stored and read back unchanged
        got = c.get(f"/plans/{created['id']}/setpoints").json()
        assert _op(got, "end-mill")["constant_load"] == cl
        assert _op(got, "end-mill")["objective"] == "mrr"


def test_rcb_raises_the_upper_limit_to_the_currents_own(server):
    with server.client("mes") as mes, server.client("engineer") as eng:
        created = eng.post("/plans", json=_named(PLAN, "cl-rcb")).json()
        plan_id, version, now = created["id"], 1, created
        uppers = [_op(created, "end-mill")["constant_load"]["feed_rate_upper_mm_min"]]
        for i in range(25):
            # the true process is the nominal model: each part draws the predicted current
            nominal = {
                op["name"]: op["predicted"]["spindle_current_A"]["value"]
                for op in now["operations"]
            }
            body = _report(f"P{i}", version, nominal)
            r = mes.post(f"/plans/{plan_id}/parts", json=body, headers={"Idempotency-Key": f"k{i}"})
            assert r.status_code == 201, r.text
            version, now = r.json()["setpoint_version"], r.json()
            uppers.append(_op(r.json(), "end-mill")["constant_load"]["feed_rate_upper_mm_min"])
        assert all(b >= a - 1e-9 for a, b in zip(uppers, uppers[1:], strict=False))
        final = _op(r.json(), "end-mill")["constant_load"]
        # fz reaches its bound 0.05 mm (1000 mm/min): Eq. 13's 983.89 mm/min governs now
        assert final["upper_governed_by"] == "current"
        assert final["feed_rate_upper_mm_min"] == pytest.approx(UPPER, rel=1e-9)


def test_feed_override_at_the_lower_limit_calls_for_a_tool_change(server):
    with server.client("mes") as mes, server.client("engineer") as eng:
        created = eng.post("/plans", json=_named(PLAN, "cl-change")).json()
        end = _op(created, "end-mill")["constant_load"]
        at_limit = 100.0 * end["feed_rate_lower_mm_min"] / end["programmed_feed_rate_mm_min"]
        url = f"/plans/{created['id']}/parts"
        r = mes.post(url, json=_report("W1", 1, 0.21, 100.0), headers={"Idempotency-Key": "w1"})
        assert r.status_code == 201, r.text
        assert [c["due"] for c in r.json()["tool_changes"]] == [False, False]
        body = _report("W2", 1, 0.21)
        body["operations"][1]["feed_override_percent"] = at_limit
        r = mes.post(url, json=body, headers={"Idempotency-Key": "w2"})
        assert r.status_code == 201, r.text
        (change,) = r.json()["tool_changes"]
        assert change["operation"] == "end-mill" and change["due"] is True
        assert change["commanded_feed_rate_mm_min"] == pytest.approx(LOWER, rel=1e-9)
        assert "180-220 µm" in change["reason"]
        stored = eng.get(url).json()["items"]
        w2 = next(p for p in stored if p["serial"] == "W2")
        op = next(o for o in w2["operations"] if o["name"] == "end-mill")
        override = op["measurements"]["feed_override_percent"]
        assert override["value"] == pytest.approx(at_limit)
        assert override["raw"]["tool_change_due"] is True


def test_bad_constant_load_input_is_refused_naming_the_field(server):
    with server.client("mes") as mes, server.client("engineer") as eng:
        bad = _named(PLAN, "cl-bad")
        bad["operations"][0]["constant_load"]["calibration"] = "nope"
        r = eng.post("/plans", json=bad)
        assert r.status_code == 422
        assert r.json()["field"] == "operations[0].constant_load.calibration"
        wrong_kind = _named(MILLING, "cl-wrong-kind")
        wrong_kind["operations"][0]["constant_load"] = {
            "calibration": "spindle_current",
            "max_current_A": 5.0,
        }
        r = eng.post("/plans", json=wrong_kind)
        assert r.status_code == 422 and "tai_current_feed" in r.json()["detail"]

        # an override for an operation without constant-load control: 422, nothing stored
        plain = eng.post("/plans", json=_named(MILLING, "cl-plain")).json()
        body = {
            "serial": "X1",
            "setpoint_version": 1,
            "operations": [{"name": "slot", "feed_override_percent": 80.0}],
        }
        r = mes.post(f"/plans/{plain['id']}/parts", json=body, headers={"Idempotency-Key": "x1"})
        assert r.status_code == 422
        assert r.json()["field"] == "operations[0].feed_override_percent"
        assert eng.get(f"/plans/{plain['id']}/parts").json()["items"] == []


def test_an_override_past_the_machines_fastest_feed_is_refused_and_nothing_stored(server):
    """Before, 1e11 % was stored, answered "commanded feed 500001169217.5 mm/min is above the
    lower limit", on a machine whose fastest feed is 2000 mm/min (max_feed_rate_mm_min)."""
    with server.client("mes") as mes, server.client("engineer") as eng:
        created = eng.post("/plans", json=_named(PLAN, "cl-fastest")).json()
        slot = _op(created, "slot")["constant_load"]
        programmed = slot["programmed_feed_rate_mm_min"]
        fastest = PLAN["machine"]["max_feed_rate_mm_min"]
        url = f"/plans/{created['id']}/parts"
        for n, percent in enumerate((1e11, 100.0 * fastest / programmed * 1.001)):
            body = {
                "serial": f"F{n}",
                "setpoint_version": 1,
                "operations": [{"name": "slot", "feed_override_percent": percent}],
            }
            r = mes.post(url, json=body, headers={"Idempotency-Key": f"f{n}"})
            assert r.status_code == 422, r.text
            problem = r.json()
            assert problem["field"] == "operations[0].feed_override_percent"
            assert problem["value"] == percent
            assert f"above the machine's maximum feed rate {fastest:g} mm/min" in problem["detail"]
        assert eng.get(url).json()["items"] == []
        at_most = 100.0 * fastest / programmed  # the fastest feed itself is a feed a control gives
        body = _report("F2", 1, 0.21)
        body["operations"][0]["feed_override_percent"] = at_most
        r = mes.post(url, json=body, headers={"Idempotency-Key": "f2"})
        assert r.status_code == 201, r.text
        (change,) = [c for c in r.json()["tool_changes"] if c["operation"] == "slot"]
        assert change["commanded_feed_rate_mm_min"] == pytest.approx(fastest, rel=1e-12)
