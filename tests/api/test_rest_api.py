"""The REST contract against a real ``rcb serve`` (uvicorn) on SQLite and PostgreSQL."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import time
import tomllib
import uuid

import httpx
import pytest
from sqlalchemy import select
from sqlalchemy.orm import Session

from api.cli.main import app
from api.rest import serving
from db import tables as t
from db.engine import make_engine, upgrade
from models.errors import InputError

from conftest import DEMO_PLAN, TABLE5_UNCERTAINTY, renamed, report_at
from live import RCB, free_port

PLAN = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
LIMITS = {op["name"]: op["limits"] for op in PLAN["operations"]}


def _post_part(client, plan_id, body, key):
    return client.post(f"/plans/{plan_id}/parts", json=body, headers={"Idempotency-Key": key})


def test_health_needs_no_key(server):
    with server.client(role=None) as c:
        r = c.get("/health")
    assert r.status_code == 200 and r.json() == {"status": "ok"}


def test_mes_loop_shrinks_bands_by_a_quarter_of_the_margin_and_replays_change_nothing(server):
    with server.client("engineer") as eng, server.client("mes") as mes:
        created = eng.post("/plans", json=renamed(PLAN), params={"strategy": "ivester"})
        assert created.status_code == 201, created.text
        plan = created.json()
        assert plan["setpoint_version"] == 1
        # Ivester & Heigel Table 5, step 1 R: 191 cm³/min at the robust start
        assert plan["operations"][0]["mrr_cm3_min"] == pytest.approx(191.2, rel=0.005)
        plan_id = plan["id"]
        setpoints = mes.get(f"/plans/{plan_id}/setpoints").json()
        assert setpoints["operations"] == plan["operations"]
        first_mrr = {op["name"]: op["mrr_cm3_min"] for op in setpoints["operations"]}
        answers, sent, exact = [], [], 0
        for i in range(10):
            body, key = report_at(f"SN-{i:03d}", setpoints), f"part-{plan_id}-{i}"
            r = _post_part(mes, plan_id, body, key)
            assert r.status_code == 201, r.text
            answer = r.json()
            assert "Idempotent-Replayed" not in r.headers
            assert answer["setpoint_version"] == setpoints["setpoint_version"] + 1
            by_op = {op["name"]: op for op in setpoints["operations"]}
            for u in answer["updates"]:
                limit = LIMITS[u["operation"]][u["quantity"]]
                made = by_op[u["operation"]]["predicted"][u["quantity"]]
                margin = limit - (made["value"] + TABLE5_UNCERTAINTY[u["quantity"]])
                assert u["margin"] == pytest.approx(margin, rel=1e-9)
                assert not u["flagged"] and margin > 0
                assert u["band_before"] == pytest.approx(made["band"], rel=1e-9)
                law = made["band"] - 0.25 * margin  # Ivester & Heigel, RCB: α = 0.25
                floor = TABLE5_UNCERTAINTY[u["quantity"]]  # the band never narrows below it
                if u["action"] == "hold":  # already at the floor (or the coverage below)
                    assert u["band_after"] == u["band_before"] and law < u["band_before"]
                elif "keeps covering" in u["reason"]:  # never narrower than a measurement seen
                    assert max(law, floor) < u["band_after"] < u["band_before"]
                else:
                    assert u["band_after"] == pytest.approx(max(law, floor), rel=1e-9)
                    exact += law > floor
            answers.append(answer)
            sent.append((body, key))
            setpoints = {"setpoint_version": answer["setpoint_version"], **answer}
        last_mrr = {op["name"]: op["mrr_cm3_min"] for op in setpoints["operations"]}
        assert all(last_mrr[name] >= first_mrr[name] * (1 - 1e-9) for name in first_mrr)
        assert last_mrr["rough-od"] > first_mrr["rough-od"] * 1.02
        assert len(answers[0]["updates"]) == 2 * len(PLAN["operations"])
        assert exact >= 20  # the binding limits shrink by exactly a quarter, part after part

        history_before = eng.get(f"/plans/{plan_id}/history").json()
        for (body, key), answer in zip(sent, answers, strict=True):
            again = _post_part(mes, plan_id, body, key)
            assert again.status_code == 201
            assert again.headers["Idempotent-Replayed"] == "true"
            assert again.json() == answer
        assert eng.get(f"/plans/{plan_id}/history").json() == history_before
        current = mes.get(f"/plans/{plan_id}/setpoints").json()
        assert current["setpoint_version"] == 11
        detail = eng.get(f"/plans/{plan_id}").json()
        assert detail["parts"] == 10 and detail["setpoint_version"] == 11


def test_parts_pages_cover_every_part_once_in_order(server):
    with server.client("engineer") as c:
        plan_id = c.post("/plans", json=renamed(PLAN), params={"strategy": "ivester"}).json()["id"]
        setpoints = c.get(f"/plans/{plan_id}/setpoints").json()
        for i in range(7):
            r = _post_part(c, plan_id, report_at(f"P{i}", setpoints), f"pg-{plan_id}-{i}")
            setpoints = r.json()
        serials, cursor = [], None
        while True:
            params = {"limit": 3, **({"cursor": cursor} if cursor else {})}
            page = c.get(f"/plans/{plan_id}/parts", params=params).json()
            serials += [p["serial"] for p in page["items"]]
            cursor = page["next_cursor"]
            if cursor is None:
                break
        assert serials == [f"P{i}" for i in range(7)]
        # a full last page ends the list: no cursor to an empty page (an integrator's review)
        whole = c.get(f"/plans/{plan_id}/parts", params={"limit": 7}).json()
        assert len(whole["items"]) == 7 and whole["next_cursor"] is None
        first = c.get(f"/plans/{plan_id}/parts", params={"limit": 1}).json()["items"][0]
        assert first["setpoint_version"] == 1
        assert first["operations"][0]["measurements"]["force_N"]["uncertainty"] == 3.0
        assert {u["action"] for u in first["updates"]} == {"shrink"}
        bad = c.get(f"/plans/{plan_id}/parts", params={"cursor": "abc"})
        assert bad.status_code == 422 and bad.json()["field"] == "cursor"


def test_history_and_model_versions_record_every_change_with_its_cause(server):
    with server.client("engineer") as c:
        plan_id = c.post("/plans", json=renamed(PLAN), params={"strategy": "ivester"}).json()["id"]
        setpoints = c.get(f"/plans/{plan_id}/setpoints").json()
        for i in range(2):
            setpoints = _post_part(
                c, plan_id, report_at(f"H{i}", setpoints), f"h-{plan_id}-{i}"
            ).json()
        history = c.get(f"/plans/{plan_id}/history").json()["versions"]
        assert [(v["version"], v["cause"], v["serial"]) for v in history] == [
            (1, "initial", None),
            (2, "part", "H0"),
            (3, "part", "H1"),
        ]
        force = [v["operations"][0]["models"]["force_N"] for v in history]
        assert [m["version"] for m in force] == [1, 2, 3]
        assert force[0]["dK"] > force[1]["dK"] > force[2]["dK"]  # the band narrows part by part
        assert force[0]["K"] == 2130.0  # Ivester & Heigel Table 2, CNMG432RN force K
        versions = c.get(
            f"/plans/{plan_id}/models/versions",
            params={"operation": "rough-od", "quantity": "force_N"},
        ).json()["versions"]
        assert [(v["version"], v["cause"], v["serial"]) for v in versions] == [
            (1, "initial", None),
            (2, "part", "H0"),
            (3, "part", "H1"),
        ]
        in_force = c.get(f"/plans/{plan_id}/models").json()["operations"]
        assert in_force[0]["models"]["force_N"]["dK"] == versions[-1]["dK"]
        # steps 2 and 3 use the same insert (VCMR331) but keep separate bands (Table 5)
        by_name = {op["name"]: op for op in in_force}
        grooves, contour = by_name["rough-grooves"], by_name["rough-contour"]
        assert grooves["tool"] == contour["tool"] == "VCMR331"
        assert grooves["models"]["force_N"]["dK"] != contour["models"]["force_N"]["dK"]
        missing = c.get(f"/plans/{plan_id}/models/versions", params={"operation": "nope"})
        assert missing.status_code == 404 and missing.json()["field"] == "operation"
        # a quantity no model of the plan has is named, not an empty list (a review, 12-02)
        missing = c.get(f"/plans/{plan_id}/models/versions", params={"quantity": "bogus"})
        assert missing.status_code == 404 and missing.json()["value"] == "bogus"
        power = c.get(f"/plans/{plan_id}/models/versions", params={"quantity": "force_N"})
        assert power.status_code == 200 and power.json()["versions"]


def test_tools_can_be_added_read_back_and_used_by_a_plan(server):
    name = f"TEST-{uuid.uuid4().hex[:8]}"
    tool = {
        "name": name,
        "process": "turning",
        "description": "a shop's own insert, fitted from test cuts",
        "material": "AISI 1045",
        "source": "test cuts 2026-11",
        "models": {
            "force_N": {
                "K": 2000.0,
                "dK": 200.0,
                "exponents": {"depth_mm": 0.9, "feed_mm_rev": 0.8},
            },
            "roughness_um": {"K": 15.0, "dK": 2.0, "exponents": {"feed_mm_rev": 1.2}},
        },
    }
    with server.client("engineer") as c, server.client("viewer") as v:
        r = c.post("/tools", json=tool)
        assert r.status_code == 201, r.text
        got = v.get(f"/tools/{name}").json()
        assert got["models"]["force_N"]["K"] == 2000.0 and got["source"] == "test cuts 2026-11"
        assert name in {x["name"] for x in v.get("/tools").json()["tools"]}
        assert "CNMG432RN" in {x["name"] for x in v.get("/tools").json()["tools"]}
        again = c.post("/tools", json=tool)
        assert again.status_code == 409 and again.json()["field"] == "name"
        plan = {**PLAN, "operations": [{**PLAN["operations"][0], "tool": name}]}
        plan["operations"][0]["limits"] = {"force_N": 2000, "roughness_um": 4.0}
        created = c.post("/plans", json=renamed(plan))
        assert created.status_code == 201, created.text
        assert created.json()["operations"][0]["tool"] == name


@pytest.mark.parametrize(
    ("role", "method", "path", "status"),
    [
        (None, "get", "/plans", 401),
        ("wrong", "get", "/plans", 401),
        ("viewer", "post", "/plans/1/parts", 403),
        ("mes", "post", "/plans", 403),
        ("mes", "post", "/tools", 403),
        ("viewer", "get", "/plans", 200),
    ],
)
def test_roles(server, role, method, path, status):
    headers = {}
    if role == "wrong":
        headers["Authorization"] = "Bearer rcb_not-a-key"
    with server.client(None if role == "wrong" else role, headers=headers) as c:
        r = getattr(c, method)(path, **({"json": {}} if method == "post" else {}))
    assert r.status_code == status, r.text
    if status >= 400:
        assert r.headers["content-type"] == "application/problem+json"
        assert r.json()["status"] == status and r.json()["field"] == "Authorization"
    if status == 401:
        assert r.headers["www-authenticate"] == "Bearer"


def test_errors_are_problems_naming_the_field(server):
    with server.client("engineer") as c:
        plan_id = c.post("/plans", json=renamed(PLAN)).json()["id"]
        setpoints = c.get(f"/plans/{plan_id}/setpoints").json()
        body = report_at("E1", setpoints)
        missing = c.post(f"/plans/{plan_id}/parts", json=body)
        assert missing.status_code == 400 and missing.json()["field"] == "Idempotency-Key"
        first = _post_part(c, plan_id, body, f"e-{plan_id}")
        assert first.status_code == 201
        reused = _post_part(c, plan_id, {**body, "serial": "E2"}, f"e-{plan_id}")
        assert reused.status_code == 422 and reused.json()["code"] == "idempotency_key_reused"
        duplicate = _post_part(c, plan_id, body, f"e-{plan_id}-other")
        assert duplicate.status_code == 409 and duplicate.json()["field"] == "serial"
        # the MES that lost the first answer finds its part (a review: the 409 did not say)
        stored = c.get(f"/plans/{plan_id}/parts").json()["items"][0]
        assert duplicate.json()["part_id"] == first.json()["part_id"] == stored["part_id"]
        assert duplicate.json()["received_at"] == stored["received_at"]
        assert f"part {stored['part_id']}, received " in duplicate.json()["detail"]
        negative = {**body, "serial": "E3"}
        negative["operations"] = [
            {"name": "rough-od", "measurements": {"force_N": {"value": -5, "uncertainty": 3}}}
        ]
        r = _post_part(c, plan_id, negative, f"e-{plan_id}-neg")
        assert r.status_code == 422
        assert r.json()["field"] == "operations[0].measurements.force_N.value"
        assert r.json()["value"] == -5
        nope = {"name": "nope", "measurements": {"force_N": {"value": 900, "uncertainty": 3}}}
        unknown = {**body, "serial": "E4", "operations": [nope]}
        r = _post_part(c, plan_id, unknown, f"e-{plan_id}-unknown")
        assert r.status_code == 422 and r.json()["field"] == "operations[0].name"
        assert "nope" in r.json()["detail"], r.json()
        future = {**body, "serial": "E5", "setpoint_version": 99}
        r = _post_part(c, plan_id, future, f"e-{plan_id}-future")
        assert r.status_code == 422 and r.json()["field"] == "setpoint_version"
        r = c.post(
            f"/plans/{plan_id}/parts",
            content=b"{not json",
            headers={"Idempotency-Key": "x", "Content-Type": "application/json"},
        )
        assert r.status_code == 400 and r.headers["content-type"] == "application/problem+json"
        assert c.get("/plans/999999/setpoints").status_code == 404
        bad_plan = {**PLAN, "machine": {**PLAN["machine"], "max_power_kW": -1}}
        r = c.post("/plans", json=bad_plan)
        assert r.status_code == 422 and r.json()["field"] == "machine.max_power_kW"
        # nothing of the refused reports was stored
        assert c.get(f"/plans/{plan_id}").json()["parts"] == 1


def test_writes_and_auth_failures_are_in_the_audit_log(server):
    with server.client(None) as anon:
        anon.get("/plans")
    with server.client("viewer") as v:
        v.post("/plans", json=renamed(PLAN))
    body = renamed(PLAN)
    with server.client("engineer") as c:
        plan_id = c.post("/plans", json=body).json()["id"]
    engine = make_engine(server.url)
    with Session(engine) as session:
        rows = session.scalars(select(t.AuditEntry).order_by(t.AuditEntry.id)).all()
        results = {(r.action, r.result) for r in rows}
    engine.dispose()
    assert ("GET /api/v1/plans", "unauthenticated") in results
    assert ("POST /api/v1/plans", "forbidden") in results
    assert ("create plan", "201") in results
    assert any(r.target == f"plan {body['name']}" and r.result == "201" for r in rows)
    assert plan_id >= 1


def test_openapi_is_served(server):
    with server.client(None) as c:
        doc = c.get("/openapi.json").json()
    assert "/api/v1/plans/{plan_id}/parts" in doc["paths"]
    assert doc["components"]["securitySchemes"]["HTTPBearer"]["scheme"] == "bearer"


def test_keys_from_the_cli_work_until_revoked(server, runner):
    created = runner.invoke(
        app, ["keys", "create", "--role", "viewer", "--db", server.url, "--json"]
    )
    assert created.exit_code == 0, created.output
    key = json.loads(created.stdout)
    assert key["role"] == "viewer" and key["key"].startswith("rcb_")
    headers = {"Authorization": f"Bearer {key['key']}"}
    with server.client(None, headers=headers) as c:
        assert c.get("/plans").status_code == 200
        revoked = runner.invoke(app, ["keys", "revoke", str(key["id"]), "--db", server.url])
        assert revoked.exit_code == 0, revoked.output
        r = c.get("/plans")
    assert r.status_code == 401 and r.json()["detail"] == "unknown or revoked API key"
    engine = make_engine(server.url)
    with Session(engine) as session:
        stored = session.get(t.ApiKey, key["id"])
        assert stored.key_hash != key["key"] and key["key"] not in stored.key_hash  # hashed
    engine.dispose()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["keys", "create", "--role", "admin"], "--role = 'admin': expected one of"),
        (["keys", "revoke", "9999"], "ID = 9999: no such API key"),
        (["keys", "revoke", "abc"], "abc"),
    ],
)
def test_key_commands_refuse_bad_input(tmp_path, runner, args, message):
    url = f"sqlite:///{tmp_path / 'k.db'}"
    upgrade(url)
    result = runner.invoke(app, [*args, "--db", url])
    assert result.exit_code == 2 and message in result.output
    assert "Traceback" not in result.output


def test_serve_migrates_a_fresh_database_on_first_start(tmp_path):
    url = f"sqlite:///{tmp_path / 'fresh.db'}"
    port = free_port()
    log = (tmp_path / "serve.log").open("wb")
    process = subprocess.Popen(
        [str(RCB), "serve", "--db", url, "--port", str(port)],
        stdout=log,
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )
    try:
        for _ in range(300):  # at most 30 s
            try:
                r = httpx.get(f"http://127.0.0.1:{port}/api/v1/health", timeout=1.0)
                break
            except httpx.HTTPError:
                assert process.poll() is None, (tmp_path / "serve.log").read_text()
                time.sleep(0.1)
        assert r.status_code == 200
        r = httpx.get(f"http://127.0.0.1:{port}/api/v1/plans", timeout=5.0)
        assert r.status_code == 401  # the tables exist: the failure was audited, not a 500
    finally:
        os.killpg(process.pid, signal.SIGTERM)
        process.wait(timeout=15)
        log.close()
    engine = make_engine(url)
    with Session(engine) as session:
        assert session.scalars(select(t.AuditEntry.result)).all() == ["unauthenticated"]
    engine.dispose()


def test_the_listener_of_several_workers_is_a_tcp_socket():
    # asyncio sets TCP_NODELAY on accepted connections only for IPPROTO_TCP listeners
    # (uvicorn's own has protocol 0: every answer then waits ~40 ms for a delayed ACK)
    listener = serving.tcp_listener("127.0.0.1", 0)
    try:
        assert listener.proto == socket.IPPROTO_TCP and listener.get_inheritable()
        port = listener.getsockname()[1]
        with pytest.raises(InputError) as err:
            serving.tcp_listener("127.0.0.1", port)  # taken: a clear error, not a traceback
        assert err.value.field == "--port"
    finally:
        listener.close()


def test_a_name_in_a_path_or_query_is_compared_as_a_body_gives_it(server):
    """NFKC, no white space around it, as a name in a body (issue 29): full-width letters and
    a trailing space found nothing before (404; an integrator's review, 2026-12-02)."""
    with server.client("engineer") as c:
        plain = c.get("/tools/CNMG432RN").json()
        for spelled in ("ＣＮＭＧ432RN", "CNMG432RN ", " CNMG432RN"):
            answer = c.get(f"/tools/{spelled}")
            assert answer.status_code == 200 and answer.json() == plain, spelled
            assert c.get(f"/tools/{spelled}/fleet/law").status_code == 200
        hidden = c.get("/tools/CNMG\u200b432RN")  # a zero-width space: refused by name
        assert hidden.status_code == 422 and hidden.json()["field"] == "name"
        plan_id = c.post("/plans", json=renamed(PLAN), params={"strategy": "ivester"}).json()["id"]
        url = f"/plans/{plan_id}/models/versions"
        plain = c.get(url, params={"operation": "rough-od"}).json()
        assert c.get(url, params={"operation": "rough-od "}).json() == plain
