"""Requests the service cannot take, answered in its words (a real ``rcb serve``, both databases).

An MES integrator's audit: an empty body, JSON nested too deeply, a lone surrogate in a string,
a path or method the service lacks, a replan with nothing to change, a misspelt quantity, a
reading field of another kind of reading; and the ``Location`` of a created tool. Each problem
names its ``field`` and ``value`` and says what to send instead.
"""

from __future__ import annotations

import itertools
import json

import pytest

from conftest import demo_body, report_at

PLAN = demo_body()
PROBLEM = "application/problem+json"
_keys = itertools.count()


def _raw(server, path, content, role="mes"):
    headers = {"Idempotency-Key": f"re-{next(_keys)}", "Content-Type": "application/json"}
    with server.client(role) as c:
        return c.post(path, content=content, headers=headers)


def _problem(r, status, code, field):
    assert r.status_code == status, r.text
    assert r.headers["content-type"] == PROBLEM
    problem = r.json()
    assert (problem["code"], problem["field"]) == (code, field), problem
    return problem


@pytest.mark.parametrize("content", [b"", b"  \r\n"])
@pytest.mark.parametrize("path", ["/plans/{id}/parts", "/plans", "/plans/{id}/replan", "/tools"])
def test_an_empty_body_is_400_malformed_json_naming_the_body(server, plan, path, content):
    r = _raw(server, path.format(id=plan["id"]), content, role="engineer")
    problem = _problem(r, 400, "malformed_json", "body")
    assert problem["detail"].startswith("the body is empty"), problem
    assert "send a JSON document" in problem["detail"]


@pytest.mark.parametrize("depth", [65, 900, 5000])
def test_json_nested_too_deeply_is_said_so(server, plan, depth):
    content = b'{"a":' * depth + b"1" + b"}" * depth
    problem = _problem(
        _raw(server, f"/plans/{plan['id']}/parts", content), 400, "malformed_json", "body"
    )
    assert "not valid JSON" not in problem["detail"]
    assert "more than 64 levels deep" in problem["detail"], problem


def test_json_nested_to_the_limit_is_read(server, plan):
    report = report_at("DEEP-64", plan)
    report["x"] = json.loads('{"a":' * 63 + "1" + "}" * 63)  # 64 levels with the body's own
    problem = _problem(
        _raw(server, f"/plans/{plan['id']}/parts", json.dumps(report).encode()), 422, "invalid", "x"
    )
    assert "nest" not in problem["detail"]


@pytest.mark.parametrize(
    ("token", "where", "field"),
    [('"X\\ud800"', "serial", "serial"), ('"\\udfff"', "name", "operations[0].name")],
)
def test_a_lone_surrogate_is_worded_as_the_service_words_it(server, plan, token, where, field):
    body = report_at("@@" if where == "serial" else "SURROGATE-1", plan)
    if where == "name":
        body["operations"][0]["name"] = "@@"
    text = json.dumps(body).replace('"@@"', token)
    problem = _problem(
        _raw(server, f"/plans/{plan['id']}/parts", text.encode()), 422, "invalid", field
    )
    said = [problem["detail"], *(e["message"] for e in problem["errors"])]
    assert not any("unable to parse" in s or "valid string" in s for s in said), said
    assert problem["errors"][0]["message"].startswith("is not valid Unicode text: a lone surrogate")


@pytest.mark.parametrize(
    ("path", "detail"),
    [
        ("/plans/", "no such path: /api/v1/plans/; did you mean /api/v1/plans?"),
        ("/plans/{id}/part", "no such path: /api/v1/plans/{id}/part"),
        (
            "/plans/{id}/parts/",
            "no such path: /api/v1/plans/{id}/parts/; did you mean /api/v1/plans/{id}/parts?",
        ),
    ],
)
def test_an_unknown_path_is_named_with_the_one_meant(server, plan, path, detail):
    path, detail = path.format(id=plan["id"]), detail.format(id=plan["id"])
    with server.client("viewer") as c:
        problem = _problem(c.get(path), 404, "not_found", "path")
    assert (problem["detail"], problem["value"]) == (detail, f"/api/v1{path}")


@pytest.mark.parametrize(
    ("method", "path", "allowed"),
    [("PUT", "/plans", "GET, HEAD, POST"), ("DELETE", "/plans/{id}/parts", "GET, HEAD, POST")],
)
def test_a_method_the_path_lacks_is_named_with_those_it_takes(server, plan, method, path, allowed):
    path = path.format(id=plan["id"])
    with server.client("engineer") as c:
        r = c.request(method, path, json={})
    problem = _problem(r, 405, "method_not_allowed", "method")
    assert r.headers["allow"] == allowed
    assert problem["value"] == method
    assert (
        problem["detail"]
        == f"the method {method} is not allowed on /api/v1{path}; allowed: {allowed}"
    )


@pytest.mark.parametrize("body", [{}, {"limits": {}}, {"reset_bands": False}])
@pytest.mark.parametrize("dry_run", [False, True])
def test_a_replan_without_a_change_names_the_body(server, plan, body, dry_run):
    with server.client("engineer") as c:
        r = c.post(
            f"/plans/{plan['id']}/replan",
            json=body,
            params={"dry_run": dry_run} if dry_run else None,
        )
    problem = _problem(r, 422, "invalid", "body")
    assert problem["value"] == body and problem["errors"][0]["field"] == "body"
    assert problem["errors"][0]["message"] == (
        "nothing to change: give one of limits, bounds, models, reset_bands, rcb"
    )


@pytest.mark.parametrize("name", ["Force_N", "force_n", "force_N ", "forse_N"])
def test_a_misspelt_quantity_is_named_with_the_one_meant(server, plan, name):
    body = report_at("MISSPELT-1", plan)
    measured = body["operations"][0]["measurements"]
    measured[name] = measured.pop("force_N")
    with server.client("mes") as c:
        r = c.post(
            f"/plans/{plan['id']}/parts",
            json=body,
            headers={"Idempotency-Key": f"re-{next(_keys)}"},
        )
    problem = _problem(r, 422, "invalid", f"operations[0].measurements.{name}")
    assert problem["value"] == name
    assert problem["errors"][0]["message"] == (
        f"unknown quantity {name!r}; did you mean force_N? measurable: force_N, roughness_um"
    )


def test_a_quantity_the_tool_does_not_model_is_still_said_so(server, plan):
    body = report_at("UNMODELLED-1", plan)
    body["operations"][0]["measurements"]["power_kW"] = {"value": 5.0, "uncertainty": 0.1}
    with server.client("mes") as c:
        r = c.post(
            f"/plans/{plan['id']}/parts",
            json=body,
            headers={"Idempotency-Key": f"re-{next(_keys)}"},
        )
    problem = _problem(r, 422, "invalid", "operations[0].measurements.power_kW")
    assert "has no model of it; measurable: force_N, roughness_um" in problem["detail"]
    assert "did you mean" not in problem["detail"]


@pytest.mark.parametrize("name", ["LOC-TOOL-1", "LOC TOOL #2?%é"])
def test_a_created_tool_has_its_location(server, name):
    tool = {
        "name": name,
        "process": "turning",
        "models": {"force_N": {"K": 2000.0, "dK": 200.0, "exponents": {"depth_mm": 0.9}}},
    }
    headers = {"Idempotency-Key": f"re-tool-{next(_keys)}"}
    with server.client("engineer") as c:
        r = c.post("/tools", json=tool, headers=headers)
        assert r.status_code == 201, r.text
        location = r.headers["location"]
        assert location.startswith("/api/v1/tools/") and "/" not in location.removeprefix(
            "/api/v1/tools/"
        )
        got = c.get(location.removeprefix("/api/v1"))
        assert got.status_code == 200 and got.json()["name"] == name
        replay = c.post("/tools", json=tool, headers=headers)
        assert replay.headers["idempotent-replayed"] == "true"
        assert replay.headers["location"] == location


def test_the_document_declares_the_location_of_a_created_tool(server):
    with server.client(None) as c:
        document = c.get("/openapi.json").json()
    created = document["paths"]["/api/v1/tools"]["post"]["responses"]["201"]["headers"]
    assert (
        created["Location"]
        == document["paths"]["/api/v1/plans"]["post"]["responses"]["201"]["headers"]["Location"]
    )


@pytest.mark.parametrize(
    ("quantity", "extra", "takes"),
    [
        ("spindle_current_A", "idle_load_V", "feed_rate_mm_min"),
        ("spindle_current_A", "workpiece_diameter_mm", "feed_rate_mm_min"),
        ("spindle_current_A", "u_idle_load_V", "feed_rate_mm_min"),
        # not ("spindle_load_V", "feed_rate_mm_min"): rcb collect sends the pass's feed rate
        # with a load reading, kept in its record (tests/api/test_collect_opcua.py)
    ],
)
def test_a_reading_field_of_another_kind_is_refused_naming_it(server, plan, quantity, extra, takes):
    body = report_at("OTHER-KIND-1", plan)
    measured = body["operations"][0]["measurements"]
    measured.pop("force_N")
    measured[quantity] = {"value": 12.0, "uncertainty": 0.1, extra: 3.0}
    with server.client("mes") as c:
        r = c.post(
            f"/plans/{plan['id']}/parts",
            json=body,
            headers={"Idempotency-Key": f"re-{next(_keys)}"},
        )
    problem = _problem(r, 422, "invalid", f"operations[0].measurements.{quantity}.{extra}")
    assert problem["value"] == 3.0
    message = problem["errors"][0]["message"]
    assert message.startswith(f"not a field of a {quantity} reading; it takes: calibration, ")
    assert takes in message and extra not in message


@pytest.mark.parametrize("name", ["LOC/TOOL", "..", "."])
def test_a_tool_name_no_url_can_reach_is_refused(server, name):
    """``A/B`` was stored, and ``GET /tools/A%2FB`` routed as ``/tools/A/B`` (404); a client
    resolves ``/tools/..`` to ``/``: no client could read such a tool."""
    tool = {
        "name": name,
        "process": "turning",
        "models": {"force_N": {"K": 2000.0, "dK": 200.0, "exponents": {"depth_mm": 0.9}}},
    }
    with server.client("engineer") as c:
        r = c.post("/tools", json=tool, headers={"Idempotency-Key": f"re-tool-{next(_keys)}"})
        problem = _problem(r, 422, "invalid", "name")
        assert "a tool's name is a segment of its URL" in problem["detail"], problem
        assert problem["value"] == name
        assert name not in [t["name"] for t in c.get("/tools").json()["tools"]]
