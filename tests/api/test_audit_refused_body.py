"""A write its route's schema refuses is in the audit log, as the service's refusals are.

An MES integrator's review: a part report refused by the service's reader (an unknown
operation) was audited, one refused by the schema before it (a negative force, NaN, malformed
JSON) was not, so a sensor that sent NaN all shift left no trace in ``rcb audit``. Through a
real server on each database; a read the schema refuses is not a write and is not logged.
"""

from __future__ import annotations

import json
import tomllib

from api.cli.main import app

from conftest import DEMO_PLAN, renamed

DEMO = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))


def _entries(runner, url: str, plan_id: int) -> list[dict]:  # type: ignore[no-untyped-def,type-arg]
    shown = runner.invoke(app, ["audit", "--plan", str(plan_id), "--db", url, "--json"])
    assert shown.exit_code == 0, shown.output
    return list(json.loads(shown.stdout)["entries"])


def test_a_report_the_schema_refuses_is_audited_as_its_actors(server, runner) -> None:
    with server.client("engineer") as c, server.client("mes") as mes:
        plan_id = c.post("/plans", json=renamed(DEMO)).json()["id"]
        url = f"/plans/{plan_id}/parts"
        negative = {"force_N": {"value": -1.0, "uncertainty": 20.0}}
        body = {"serial": "A1", "setpoint_version": 1}
        body["operations"] = [{"name": "rough-od", "measurements": negative}]
        refused = mes.post(url, json=body, headers={"Idempotency-Key": "a1"})
        assert refused.status_code == 422, refused.text
        broken = mes.post(
            url,
            content=b'{"serial": "A2", ',
            headers={"Idempotency-Key": "a2", "Content-Type": "application/json"},
        )
        assert broken.status_code == 400 and broken.json()["code"] == "malformed_json"
        read = mes.get(url, params={"limit": 0})  # a read: not logged
        assert read.status_code == 422, read.text
        body["operations"][0]["measurements"] = {"force_N": {"value": 900.0, "uncertainty": 20.0}}
        assert mes.post(url, json=body, headers={"Idempotency-Key": "a3"}).status_code == 201
    entries = _entries(runner, server.url, plan_id)  # newest first
    accepted = next(e for e in entries if e["target"] == f"plan {plan_id} part A1")
    refused = [e for e in entries if e["result"] == "refused"]
    # as the service's refusals (rcb audit --action 'report part'); malformed JSON is refused
    # before the key is read: no actor, not logged
    assert [(e["actor"], e["action"], e["detail"]["error"]) for e in refused] == [
        (accepted["actor"], "report part", "invalid")
    ]
    assert refused[0]["detail"]["field"] == "operations[0].measurements.force_N.value"
    assert refused[0]["target"] == f"plan {plan_id}"
