"""Issue 18 item 9, against a real ``rcb serve`` on SQLite and PostgreSQL: a JSON route answers
a body sent as anything but ``application/json`` (curl's ``-d`` default is a form) with 415
problem+json naming ``Content-Type``, and nothing is stored; JSON with ``charset=utf-8`` is
taken; the 415 is in the OpenAPI document of every route that takes a body.
"""

from __future__ import annotations

import itertools
import json
import socket

import pytest

from api.rest.content_type import accepted

from conftest import demo_body

PLAN = demo_body()
TOOL = {
    "name": "CT-TEST-1",
    "process": "turning",
    "description": "an insert of the content-type test",
    "models": {"force_N": {"K": 2000.0, "dK": 200.0, "exponents": {"depth_mm": 0.9}}},
}
_keys = itertools.count()
FORM = "application/x-www-form-urlencoded"
#: Every route taking a JSON body (POST), with a body it would accept.
ROUTES = ["/plans", "/plans/{id}/parts", "/plans/{id}/replan", "/tools"]


def _body(route: str, plan: dict) -> dict:
    return {
        "/plans": {**PLAN, "name": f"ct-{next(_keys)}"},
        "/plans/{id}/parts": {
            "serial": f"CT-{next(_keys)}",
            "setpoint_version": plan["setpoint_version"],
            "operations": [
                {"name": "rough-od", "measurements": {"force_N": {"value": 900, "uncertainty": 3}}}
            ],
        },
        "/plans/{id}/replan": {"reset_bands": True},
        "/tools": {**TOOL, "name": f"CT-{next(_keys)}"},
    }[route]


def _send(server, plan, route, body: bytes, headers: dict[str, str]):
    headers = {"Idempotency-Key": f"ct-{next(_keys)}", **headers}
    with server.client("engineer") as c:
        return c.post(route.replace("{id}", str(plan["id"])), content=body, headers=headers)


def _counts(server, plan) -> tuple[int, int, int, int]:
    with server.client("viewer") as c:
        plans = len(c.get("/plans").json()["plans"])
        parts = len(c.get(f"/plans/{plan['id']}/parts", params={"limit": 500}).json()["items"])
        tools = len(c.get("/tools").json()["tools"])
        versions = c.get(f"/plans/{plan['id']}").json()["setpoint_version"]
    return plans, parts, tools, versions


@pytest.mark.parametrize("route", ROUTES)
@pytest.mark.parametrize(
    "content_type",
    [FORM, "text/plain", None, "application/problem+json", "application/json; charset=latin-1"],
    ids=["form", "text", "none", "problem-json", "latin-1"],
)
def test_a_body_not_sent_as_json_is_415_naming_content_type(server, plan, route, content_type):
    before = _counts(server, plan)
    body = json.dumps(_body(route, plan)).encode()
    headers = {} if content_type is None else {"Content-Type": content_type}
    r = _send(server, plan, route, body, headers)
    assert r.status_code == 415, r.text
    assert r.headers["content-type"] == "application/problem+json"
    assert r.headers["accept-post"] == "application/json"
    problem = r.json()
    assert problem["status"] == 415
    assert problem["code"] == "unsupported_media_type"
    assert problem["field"] == "Content-Type"
    assert problem["value"] == content_type
    assert "Content-Type: application/json" in problem["detail"]
    assert "valid dictionary" not in r.text  # the old 422 with the raw bytes
    assert _counts(server, plan) == before  # nothing stored


def test_curl_dash_d_form_fields_get_415_not_422(server, plan):
    # what `curl -d name=x URL` sends: the reproduction
    r = _send(server, plan, "/plans", b"name=x&machine=y", {"Content-Type": FORM})
    assert r.status_code == 415, r.text
    assert f"Content-Type '{FORM}'" in r.json()["detail"]


@pytest.mark.parametrize("route", ROUTES)
@pytest.mark.parametrize(
    "content_type",
    ["application/json", "application/json; charset=utf-8", 'Application/JSON;charset="UTF-8"'],
    ids=["plain", "utf-8", "spelled-otherwise"],
)
def test_json_is_taken_with_or_without_utf8_charset(server, plan, route, content_type):
    body = json.dumps(_body(route, plan)).encode()
    r = _send(server, plan, route, body, {"Content-Type": content_type})
    assert r.status_code == 201, r.text


def test_a_post_without_a_body_is_still_the_422_of_a_missing_body(server, plan):
    with server.client("engineer") as c:
        r = c.post("/tools", headers={"Idempotency-Key": f"ct-{next(_keys)}"})
    assert r.status_code == 422, r.text
    assert r.json()["field"] == "body"


def test_a_chunked_form_body_is_415(server, plan):
    # no Content-Length: the body is announced by Transfer-Encoding alone
    host, port = "127.0.0.1", server.port
    request = (
        f"POST /api/v1/tools HTTP/1.1\r\nHost: {host}\r\n"
        f"Authorization: Bearer {server.keys['engineer']}\r\n"
        f"Content-Type: {FORM}\r\nTransfer-Encoding: chunked\r\nConnection: close\r\n\r\n"
        "5\r\nname=\r\n0\r\n\r\n"
    ).encode()
    with socket.create_connection((host, port), timeout=30) as s:
        s.sendall(request)
        reply = b""
        while chunk := s.recv(65536):
            reply += chunk
    assert reply.startswith(b"HTTP/1.1 415"), reply[:200]


def test_the_openapi_document_lists_415_on_every_route_with_a_body(server):
    with server.client(None) as c:
        document = c.get("/openapi.json").json()
    with_body = {
        (path, method): operation
        for path, item in document["paths"].items()
        for method, operation in item.items()
        if "requestBody" in operation
    }
    assert {path for path, _ in with_body} == {
        "/api/v1" + r.replace("{id}", "{plan_id}") for r in ROUTES
    }
    for operation in with_body.values():
        content = operation["responses"]["415"]["content"]
        assert content["application/problem+json"]["schema"] == {
            "$ref": "#/components/schemas/Problem"
        }
    without = [op for item in document["paths"].values() for op in item.values()]
    assert all("415" not in op["responses"] for op in without if "requestBody" not in op)


@pytest.mark.parametrize(
    ("content_type", "taken"),
    [
        ("application/json", True),
        ("application/json;charset=utf-8", True),
        ("APPLICATION/JSON ; CHARSET=UTF-8", True),
        ("application/json; charset=utf-16", False),
        ("application/json; boundary=x", False),
        ("application/jsonx", False),
        ("application/problem+json", False),
        ("multipart/form-data; boundary=x", False),
        ("", False),
        (None, False),
    ],
)
def test_accepted_media_types(content_type, taken):
    assert accepted(content_type) is taken
