"""A violation halts, it never vanishes (issue 15, point 3): through a real ``rcb serve``.

On the demonstration plan (strategy ``ivester``) a rough-od part at 6000 N is a breach that
grows the force band (a new version); a second one at 10000 N, made with that version, leaves
no setpoint under the grown band: the part is still stored whole, the answer is 201 with
``halted`` and the conflicts, setpoints are refused with 409 ``plan_halted`` until a replan.
"""

from __future__ import annotations

import json
import tomllib

import pytest
from typer.testing import CliRunner

from api.cli.main import app

from conftest import DEMO_PLAN, renamed

PLAN = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
U_N = 10.0  # the force measurements' uncertainty [N]


def _force_report(serial: str, version: int, force_N: float) -> dict:
    return {
        "serial": serial,
        "setpoint_version": version,
        "operations": [
            {
                "name": "rough-od",
                "measurements": {"force_N": {"value": force_N, "uncertainty": U_N}},
            }
        ],
    }


def _post(client, plan_id, body):
    key = f"halt-{plan_id}-{body['serial']}"
    return client.post(f"/plans/{plan_id}/parts", json=body, headers={"Idempotency-Key": key})


def _force_update(answer: dict) -> dict:
    (update,) = [u for u in answer["updates"] if u["quantity"] == "force_N"]
    return update


def test_an_over_limit_part_halts_the_plan_is_stored_and_a_replan_resumes(server):
    with server.client("engineer") as eng, server.client("mes") as mes:
        created = eng.post("/plans", params={"strategy": "ivester"}, json=renamed(PLAN))
        assert created.status_code == 201, created.text
        plan_id = created.json()["id"]
        assert eng.get(f"/plans/{plan_id}").json()["status"] == "running"

        # 2300 N on the 2000 N limit: a breach (15 %, under halt_over 25 %); the band grows
        first = _post(mes, plan_id, _force_report("SN-2300", 1, 2300.0))
        assert first.status_code == 201, first.text
        one = first.json()
        assert one["halted"] is False and one["conflicts"] == []
        assert one["setpoint_version"] == 2
        breach = _force_update(one)
        assert breach["flag"] == "breach" and breach["flagged"] and breach["action"] == "expand"
        assert breach["note"] is None
        # far over the prediction, the margin reads y + Q u, Q = 3.1458193 (the chain's bound
        # scale) before its noise is known (supervisor.rcb.law): 2000 − (2300 + 31.46) = −331.46 N
        assert breach["margin"] == pytest.approx(2000 - 2300 - 3.1458193 * U_N, rel=1e-8)

        # 6000 N: past the limit by 200 % - 10 N, more than halt_over: the plan halts at once
        second = _post(mes, plan_id, _force_report("SN-6000", 2, 6000.0))
        assert second.status_code == 201, second.text
        two = second.json()
        assert two["halted"] is True
        assert two["setpoint_version"] == 2  # the setpoints the part was made with stay
        # no setpoint is handed out while halted, as GET .../setpoints refuses them
        assert one["operations"] and two["operations"] == []
        assert [c["operation"] for c in two["conflicts"]] == ["rough-od"]
        rough = two["conflicts"][0]
        assert (
            "rough-od force_N measured 6000 - 10 = 5990 is past its limit 2000 by 199.5 %"
            in rough["message"]
        )
        assert "halt_over 25 %" in rough["message"]
        assert _force_update(two)["flag"] == "breach"

        refused = mes.get(f"/plans/{plan_id}/setpoints")
        assert refused.status_code == 409
        assert refused.headers["content-type"].startswith("application/problem+json")
        problem = refused.json()
        assert problem["code"] == "plan_halted" and problem["status"] == 409
        assert problem["conflicts"] == two["conflicts"]

        # a late part made with the first version is still accepted and stored
        late = _post(mes, plan_id, _force_report("SN-late", 1, 1900.0))
        assert late.status_code == 201, late.text
        assert late.json()["halted"] is True and late.json()["operations"] == []

        parts = eng.get(f"/plans/{plan_id}/parts").json()["items"]
        assert [p["serial"] for p in parts] == ["SN-2300", "SN-6000", "SN-late"]
        by_serial = {p["serial"]: p for p in parts}
        measured = by_serial["SN-6000"]["operations"][0]["measurements"]["force_N"]
        assert (measured["value"], measured["uncertainty"]) == (6000.0, U_N)
        stored = by_serial["SN-6000"]["updates"][0]
        assert stored["flag"] == "breach" and stored["flagged"]
        assert stored["band_after"] == pytest.approx(_force_update(two)["band_after"])
        _halt_audited(server.url, plan_id)
        history = eng.get(f"/plans/{plan_id}/history").json()
        assert history["status"] == "halted" and history["halt"]["conflicts"] == two["conflicts"]
        assert [v["version"] for v in history["versions"]] == [1, 2]
        listed = {p["id"]: p for p in eng.get("/plans").json()["plans"]}
        assert listed[plan_id]["status"] == "halted"

        resumed = eng.post(
            f"/plans/{plan_id}/replan",
            json={"reset_bands": True},
            headers={"Idempotency-Key": f"resume-{plan_id}"},
        )
        assert resumed.status_code == 201, resumed.text
        assert resumed.json()["setpoint_version"] == 3
        again = mes.get(f"/plans/{plan_id}/setpoints")
        assert again.status_code == 200, again.text
        assert again.json()["setpoint_version"] == 3
        detail = eng.get(f"/plans/{plan_id}").json()
        assert detail["status"] == "running" and detail["halt"] is None
        assert detail["parts"] == 3
        after = _post(mes, plan_id, _force_report("SN-after", 3, 1500.0))
        assert after.status_code == 201 and after.json()["halted"] is False
        assert after.json()["operations"]  # handed out again after the replan


def _halt_audited(url: str, plan_id: int) -> None:
    """The halt is in the audit log, found by ``rcb audit --action halt``: which part, which
    operations and why (before, it was only the part report's 201 entry)."""
    done = CliRunner().invoke(
        app, ["audit", "--action", "halt", "--plan", str(plan_id)] + ["--json", "--db", url]
    )
    assert done.exit_code == 0, done.output
    (entry,) = json.loads(done.stdout)["entries"]  # one: the late part halted nothing new
    assert (entry["actor"], entry["target"], entry["result"]) == (
        "rcb",
        f"plan {plan_id}",
        "halted until a replan",
    )
    detail = entry["detail"]
    assert (detail["part"], detail["operations"]) == ("SN-6000", ["rough-od"])
    assert "replan" in detail["message"]


@pytest.mark.parametrize("floor", [None, 50.0])
def test_a_reading_under_the_band_shrinks_it_by_a_quarter_of_the_margin_with_a_note(server, floor):
    """One-sided law: 1600 ± 10 N under a band whose limit is 2000 N is no violation."""
    params = {"strategy": "ivester"} | ({"floor": f"force_N={floor}"} if floor else {})
    with server.client("engineer") as eng, server.client("mes") as mes:
        created = eng.post("/plans", params=params, json=renamed(PLAN))
        assert created.status_code == 201, created.text
        plan_id = created.json()["id"]
        settings = eng.get(f"/plans/{plan_id}").json()["settings"]
        assert settings["floors"] == ({"force_N": floor} if floor else {})
        start = mes.get(f"/plans/{plan_id}/setpoints").json()
        made = next(o for o in start["operations"] if o["name"] == "rough-od")
        value, band = made["predicted"]["force_N"]["value"], made["predicted"]["force_N"]["band"]
        # the robust start: the force band's upper edge on the 2000 N limit (Table 5 step 1 R)
        # at the continuous optimum; at its grid point d 2.943, f 0.3248, v 200 just under it:
        # (2130 + 150) · 2.943^0.888 · 0.3248^0.783 · 200^-0.0395 = 1999.518 N (Table 2)
        assert made["setpoint"] == {"depth_mm": 2.943, "feed_mm_rev": 0.3248, "speed_m_min": 200}
        assert value + band == pytest.approx(1999.518, abs=1e-3)
        assert 1600.0 + U_N < value - band  # the reading lies under the band's lower edge
        answer = _post(mes, plan_id, _force_report("SN-below", 1, 1600.0))
        assert answer.status_code == 201, answer.text
        body = answer.json()
        assert body["halted"] is False
        update = _force_update(body)
        assert update["action"] == "shrink"
        assert update["flagged"] is False and update["flag"] is None
        assert update["note"] == "below_band"
        margin = 2000.0 - (1600.0 + U_N)  # 390 N
        assert update["margin"] == pytest.approx(margin, rel=1e-12)
        assert update["band_before"] == pytest.approx(band, rel=1e-9)
        least = floor if floor else U_N  # the plan's floor, else the measurement's uncertainty
        assert update["band_after"] == pytest.approx(max(band - 0.25 * margin, least), rel=1e-9)
        assert body["setpoint_version"] == 2  # a narrower band: a faster setpoint
        stored = eng.get(f"/plans/{plan_id}/parts").json()["items"][0]["updates"][0]
        assert (stored["flag"], stored["note"], stored["flagged"]) == (None, "below_band", False)
