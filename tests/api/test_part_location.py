"""A reported part's 201 says where it is, and the part is there (RFC 9110 §15.3.2).

An MES integrator's review: a part report's 201 had no ``Location`` (a part had no path of
its own): to show what was stored for one part, the MES paged through the plan's parts. Now
``Location: /api/v1/plans/{id}/parts/{part_id}``, a replay of the same key answers the same,
and ``GET`` there is the part as the pages list it (Ivester & Heigel Table 5's step 1 force
measured at 90 % of its prediction). Through a real server on each database.
"""

from __future__ import annotations

import tomllib

import httpx

from conftest import DEMO_PLAN, renamed, report_at

DEMO = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))


def test_a_reported_part_is_located_and_read_there(server) -> None:
    with server.client("engineer") as c, server.client("mes") as mes:
        plan_id = c.post("/plans", json=renamed(DEMO)).json()["id"]
        other = c.post("/plans", json=renamed(DEMO)).json()["id"]
        setpoints = mes.get(f"/plans/{plan_id}/setpoints").json()
        body = report_at("P-1", setpoints, fraction=0.9)
        key = {"Idempotency-Key": "p-1"}
        made = mes.post(f"/plans/{plan_id}/parts", json=body, headers=key)
        assert made.status_code == 201, made.text
        part_id = made.json()["part_id"]
        where = made.headers["location"]
        assert where == f"/api/v1/plans/{plan_id}/parts/{part_id}"
        root = server.base.removesuffix("/api/v1")
        shown = httpx.get(root + where, headers=mes.headers, timeout=60.0)
        assert shown.status_code == 200, shown.text
        listed = mes.get(f"/plans/{plan_id}/parts").json()["items"]
        assert shown.json() == listed[0]  # the part as the page lists it
        force = {op["name"]: op["measurements"]["force_N"] for op in shown.json()["operations"]}
        first = next(op for op in setpoints["operations"] if op["name"] == "rough-od")
        assert force["rough-od"]["value"] == 0.9 * first["predicted"]["force_N"]["value"]
        again = mes.post(f"/plans/{plan_id}/parts", json=body, headers=key)
        assert again.headers["idempotent-replayed"] == "true"
        assert again.content == made.content  # byte for byte (was re-encoded: other spacing)
        assert (again.status_code, again.headers["location"]) == (201, where)
        # another plan's part, a part not stored, an id out of range: as a plan not found
        for path, field in (
            (f"/plans/{other}/parts/{part_id}", "part_id"),
            (f"/plans/{plan_id}/parts/{part_id + 1}", "part_id"),
        ):
            missing = mes.get(path)
            assert missing.status_code == 404, missing.text
            assert missing.headers["content-type"].startswith("application/problem+json")
            assert missing.json()["field"] == field
        assert mes.get(f"/plans/{plan_id}/parts/0").status_code == 422
        document = c.get("/openapi.json").json()
    declared = document["paths"]["/api/v1/plans/{plan_id}/parts"]["post"]["responses"]["201"]
    assert "Location" in declared["headers"]
    assert "get" in document["paths"]["/api/v1/plans/{plan_id}/parts/{part_id}"]
