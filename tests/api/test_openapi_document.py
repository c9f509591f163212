"""The OpenAPI document is stable and says what the service does (issue 30, point 6).

Every operation has its own short operationId (a generated client's method names); every
operation declares the problem statuses its route can answer and no other; the tables keyed by
quantity or parameter name are typed, their names from the registries; problems' ``errors``
and ``conflicts`` are typed. A live server shows a declared status answered and an undeclared
one not.
"""

from __future__ import annotations

import re

import httpx
import pytest
from fastapi.routing import APIRoute

from api.rest.app import create_app
from api.rest.schemas.parts import MEASURABLE
from models.kinematics import PARAMETERS
from models.quantities import QUANTITIES

from migrated import migrated

#: Per operation, every status it declares (issue 30: what each route can answer, no more).
#: 400 on every operation: a request the HTTP parser refuses (api.rest.heads), before any route
STATUSES = {
    "getHealth": {200, 400, 413, 414, 431, 503},
    "getReady": {200, 400, 413, 414, 431, 503},
    "createPlan": {201, 400, 401, 403, 409, 413, 414, 415, 422, 429, 431, 500, 503},
    "listPlans": {200, 400, 401, 413, 414, 422, 429, 431, 503},
    "replanPlan": {200, 201, 400, 401, 403, 404, 409, 413, 414, 415, 422, 429, 431, 500, 503},
    "getPlan": {200, 400, 401, 404, 413, 414, 422, 429, 431, 503},
    "getSetpoints": {200, 400, 401, 404, 409, 413, 414, 422, 429, 431, 503},
    "reportPart": {201, 400, 401, 403, 404, 409, 413, 414, 415, 422, 429, 431, 500, 503},
    "listParts": {200, 400, 401, 404, 413, 414, 422, 429, 431, 503},
    "getPart": {200, 400, 401, 404, 413, 414, 422, 429, 431, 503},
    "getHistory": {200, 400, 401, 404, 413, 414, 422, 429, 431, 503},
    "getModels": {200, 400, 401, 404, 413, 414, 422, 429, 431, 503},
    "listModelVersions": {200, 400, 401, 404, 413, 414, 422, 429, 431, 503},
    "listTools": {200, 400, 401, 413, 414, 422, 429, 431, 503},
    "getTool": {200, 400, 401, 404, 413, 414, 422, 429, 431, 503},
    "getToolFleet": {200, 400, 401, 404, 413, 414, 422, 429, 431, 503},
    "getToolFleetImported": {200, 400, 401, 404, 413, 414, 422, 429, 431, 503},
    "getToolFleetLaw": {200, 400, 401, 404, 409, 413, 414, 422, 429, 431, 503},
    "addTool": {201, 400, 401, 403, 409, 413, 414, 415, 422, 429, 431, 503},
}
PROBLEM = {"$ref": "#/components/schemas/Problem"}


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    url = f"sqlite:///{tmp_path_factory.mktemp('openapi') / 'rcb.db'}"
    migrated(url)
    return create_app(url)


@pytest.fixture(scope="module")
def document(app):
    return app.openapi()


def _operations(document):
    return [op for item in document["paths"].values() for op in item.values()]


def test_every_route_names_its_operation_once(app, document):
    routes = [r for r in app.routes if isinstance(r, APIRoute) and r.include_in_schema]
    named = [r.operation_id for r in routes]
    assert None not in named, [r.path for r in routes if r.operation_id is None]
    ids = [op["operationId"] for op in _operations(document)]
    assert sorted(ids) == sorted(named) and len(set(ids)) == len(ids)
    assert all(re.fullmatch(r"[a-z]+(?:[A-Z][a-z]+)+", i) for i in ids), ids
    assert set(ids) == set(STATUSES)


def test_each_operation_declares_what_it_can_answer(document):
    declared = {
        op["operationId"]: {int(status) for status in op["responses"]}
        for op in _operations(document)
    }
    assert declared == STATUSES


def test_every_error_is_a_problem_document(document):
    for op in _operations(document):
        for status, response in op["responses"].items():
            if int(status) >= 400:
                assert response["content"] == {"application/problem+json": {"schema": PROBLEM}}, (
                    op["operationId"],
                    status,
                )
                assert response["description"], (op["operationId"], status)


def test_retry_after_and_www_authenticate_are_declared(document):
    for op in _operations(document):
        responses = op["responses"]
        for status, header in (("429", "Retry-After"), ("503", "Retry-After")):
            if status in responses:
                assert header in responses[status]["headers"], op["operationId"]
        if "401" in responses:
            assert "WWW-Authenticate" in responses["401"]["headers"]


def _table(document, name):
    schema = document["components"]["schemas"][name]
    assert schema["additionalProperties"] is False and "required" not in schema
    for prop in schema["properties"].values():  # optional, never null
        assert "anyOf" not in prop and "default" not in prop and prop.get("type") != "null"
    return schema["properties"]


def test_tables_of_names_are_typed_from_the_registries(document):
    parameters = {p for names in PARAMETERS.values() for p in names}
    assert set(_table(document, "Setpoint")) == parameters
    assert {p["type"] for p in _table(document, "Setpoint").values()} == {"number"}
    predicted = _table(document, "Predicted")
    assert list(predicted) == list(QUANTITIES)
    assert {p["$ref"] for p in predicted.values()} == {"#/components/schemas/Band"}
    measurements = _table(document, "Measurements")
    assert list(measurements) == MEASURABLE and "spindle_load_V" in measurements
    assert {p["$ref"] for p in measurements.values()} == {"#/components/schemas/ReadingIn"}
    # a stored part: also a constant-load operation's reported feed override, and tool life as
    # a report gave it before it was refused (a page holding one was a 500: a review)
    stored = [*MEASURABLE, "feed_override_percent", "tool_life_mm3"]
    assert list(_table(document, "MeasurementsOut")) == stored


def test_the_tables_are_used_where_the_names_are(document):
    schemas = document["components"]["schemas"]
    for model in ("OperationSetpoint", "PassGroupOut", "HistoryOperation"):
        props = schemas[model]["properties"]
        assert props["setpoint"] == {"$ref": "#/components/schemas/Setpoint"}, model
        assert props["predicted"] == {"$ref": "#/components/schemas/Predicted"}, model
    report = schemas["OperationReport"]["properties"]["measurements"]
    assert report["$ref"] == "#/components/schemas/Measurements"
    stored = schemas["PartOperation"]["properties"]["measurements"]
    assert stored == {"$ref": "#/components/schemas/MeasurementsOut"}


def test_problem_fields_are_typed(document):
    problem = document["components"]["schemas"]["Problem"]["properties"]
    conflicts = [b for b in problem["conflicts"]["anyOf"] if b.get("type") == "array"]
    assert conflicts == [
        {"type": "array", "items": {"$ref": "#/components/schemas/HaltedOperationOut"}}
    ]
    errors = [b for b in problem["errors"]["anyOf"] if b.get("type") == "array"]
    assert errors == [{"type": "array", "items": {"$ref": "#/components/schemas/FieldError"}}]
    halted = document["components"]["schemas"]["HaltedOperationOut"]["properties"]
    assert halted["conflicts"]["items"] == {"$ref": "#/components/schemas/ConflictOut"}


def test_health_answers_what_it_declares(sqlite_server):
    with httpx.Client(base_url=sqlite_server.base, timeout=60) as c:
        # a wrong key changes nothing: /health takes none, so it cannot answer 401
        assert c.get("/health", headers={"Authorization": "Bearer nope"}).status_code == 200
        large = c.request("GET", "/health", content=b"x" * 1_100_000)
    assert large.status_code == 413
    assert large.headers["content-type"] == "application/problem+json"
    assert large.json()["code"] == "body_too_large"


def test_an_unauthenticated_read_is_a_declared_401(sqlite_server):
    with sqlite_server.client(None) as c:
        answer = c.get("/plans")
    assert answer.status_code == 401 and answer.headers["WWW-Authenticate"] == "Bearer"


@pytest.mark.parametrize(
    ("operation_id", "model", "nested"),
    [
        ("createPlan", "PlanIn", {"MachineIn", "OperationIn", "ToolIn", "RcbSettingsIn"}),
        ("addTool", "ToolIn", {"ModelIn"}),
    ],
)
def test_a_body_a_reader_checks_is_documented_by_its_schema(document, operation_id, model, nested):
    """Issue 31: the route takes the JSON object for its reader; the document names the schema."""
    operation = next(o for o in _operations(document) if o["operationId"] == operation_id)
    body = operation["requestBody"]
    assert body["required"] is True
    assert body["content"]["application/json"]["schema"] == {
        "$ref": f"#/components/schemas/{model}"
    }
    schemas = document["components"]["schemas"]
    assert {model, *nested} <= set(schemas)
    assert schemas[model]["additionalProperties"] is False
    if operation_id == "createPlan":  # the example stays
        assert "one operation" in body["content"]["application/json"]["examples"]
