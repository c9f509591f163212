"""A refused request is answered in the service's words: the field, the value, what is allowed.

pydantic's own sentences ("Value error, ...", "Input should be ...", a pattern's regular
expression) reached the 422s of the REST schemas; :func:`api.rest.schemas.common.plain_message`
words each of them as the domain readers word theirs.
"""

from __future__ import annotations

import copy
import itertools
import re
import tomllib
from typing import Any

import pytest
from fastapi.testclient import TestClient

from api.rest.app import create_app
from api.rest.schemas.common import PATTERN_WORDS
from api.rest.schemas.parts import parse_report
from api.services.keys import create_key
from models.errors import InputError

from conftest import DEMO_PLAN, report_at
from migrated import migrated

PLAN = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
#: pydantic's wording, none of which a problem may carry.
PYDANTIC = re.compile(
    r"Value error|Input should|String should|List should|Field required|should match pattern|"
    r"Extra inputs|valid dictionary|greater than or equal|less than or equal|\^\[|\{1,"
)
_keys = itertools.count()
FORCE = ("operations", 0, "measurements", "force_N")
FORCE_FIELD = "operations[0].measurements.force_N"


@pytest.fixture(scope="module")
def service(tmp_path_factory):
    """A client of the app on SQLite, its keys by role, and a plan's first setpoints."""
    url = f"sqlite:///{tmp_path_factory.mktemp('wording')}/rcb.db"
    migrated(url)
    app = create_app(url)
    engine = app.state.engine
    keys = {r: create_key(engine=engine, role=r)["key"] for r in ("engineer", "mes", "viewer")}
    with TestClient(app) as client:
        r = _call(client, keys["engineer"], "POST", "/plans", json={**PLAN, "name": "wording"})
        assert r.status_code == 201, r.text
        yield client, keys, r.json()


def _call(client, key, method, path, **kw):
    headers = {"Authorization": f"Bearer {key}"}
    if method == "POST":
        headers["Idempotency-Key"] = f"w-{next(_keys)}"
    return client.request(method, f"/api/v1{path}", headers=headers, **kw)


def _changed(body: dict[str, Any], path: tuple[Any, ...], value: Any) -> dict[str, Any]:
    """``body`` with the item at ``path`` set to ``value`` (deleted: ``...``)."""
    body = copy.deepcopy(body)
    target = body
    for key in path[:-1]:
        target = target[key]
    if value is ...:
        del target[path[-1]]
    else:
        target[path[-1]] = value
    return body


def _assert_worded(problem: dict[str, Any], field: str, value: Any, allowed: str) -> None:
    """No pydantic phrase; ``field`` named with ``value``; ``allowed`` said."""
    said = [problem["detail"], *(e["message"] for e in problem["errors"])]
    assert not any(PYDANTIC.search(text) for text in said), said
    assert problem["field"] == field
    assert problem["errors"][0]["field"] == field
    if value is ...:
        assert problem["value"] is None
        assert problem["detail"] == f"{field}: {allowed}"
    else:
        assert problem["detail"] == f"{field} = {value!r}: {allowed}"
    assert problem["errors"][0]["message"] == allowed


REPORTS = [
    (("serial",), ..., "serial", "required field missing"),
    (("serial",), "  ", "serial", "must not be blank: some visible character"),
    (("serial",), "", "serial", "must not be blank: some visible character"),
    (("serial",), 5, "serial", "must be text (a JSON string)"),
    (("serial",), "P\x01", "serial", "must not contain control characters (U+0001 at 1)"),
    (("serial",), "P\x00", "serial", "must not contain NUL characters"),
    (("setpoint_version",), "1", "setpoint_version", "must be a whole number"),
    (("setpoint_version",), 0, "setpoint_version", "must be at least 1"),
    (("operations",), [], "operations", "must have at least 1 item(s)"),
    (("operations",), "x", "operations", "must be a list"),
    ((*FORCE, "value"), "5", f"{FORCE_FIELD}.value", "must be a number"),
    ((*FORCE, "value"), 0, f"{FORCE_FIELD}.value", "must be at least 1e-09"),
    ((*FORCE, "value"), 1e308, f"{FORCE_FIELD}.value", "must be at most 1e+12"),
    ((*FORCE, "uncertainty"), ..., f"{FORCE_FIELD}.uncertainty", "required field missing"),
    (("operations", 0, "name"), "a\tb", "operations[0].name", "must not contain control "
     "characters (U+0009 at 1)"),
    (("operations", 0, "measurements"), {}, "operations[0].measurements",
     "nothing measured: give a measurement, tool_wear or feed_override_percent"),
    (("bogus",), 1, "bogus", "unknown field; expected one of: serial, setpoint_version, "
     "operations"),
    (("serail",), "S-1", "serail", "unknown field (did you mean 'serial'?); expected one of: "
     "serial, setpoint_version, operations"),
    ((*FORCE, "bogus"), 1, f"{FORCE_FIELD}.bogus", "unknown field; expected one of: value, "
     "uncertainty, calibration, spindle_speed_rpm, workpiece_diameter_mm, "
     "u_workpiece_diameter_mm, idle_load_V, u_idle_load_V, feed_rate_mm_min, u_feed_rate_mm_min"),
]  # fmt: skip


@pytest.mark.parametrize(("path", "value", "field", "allowed"), REPORTS)
def test_a_refused_report_names_the_field_the_value_and_what_is_allowed(
    service, path, value, field, allowed
):
    client, keys, plan = service
    body = _changed(report_at(f"W-{next(_keys)}", plan), path, value)
    r = _call(client, keys["mes"], "POST", f"/plans/{plan['id']}/parts", json=body)
    assert r.status_code == 422, r.text
    _assert_worded(r.json(), field, value, allowed)


def test_an_uncertainty_over_its_value_is_said_without_pydantic_s_prefix(service):
    client, keys, plan = service
    body = _changed(report_at("W-unc", plan), (*FORCE, "uncertainty"), 5000.0)
    value = body["operations"][0]["measurements"]["force_N"]["value"]
    r = _call(client, keys["mes"], "POST", f"/plans/{plan['id']}/parts", json=body)
    assert r.status_code == 422, r.text
    _assert_worded(
        r.json(), f"{FORCE_FIELD}.uncertainty", 5000.0, f"must be less than the value {value:g}"
    )


def test_a_body_that_is_no_object_is_said_so(service):
    client, keys, plan = service
    r = _call(client, keys["mes"], "POST", f"/plans/{plan['id']}/parts", json=[1])
    assert r.status_code == 422, r.text
    _assert_worded(r.json(), "body", [1], "must be an object of named fields")


NEXT = "must be the previous page's next_cursor: "
QUERIES = [
    ("/plans/{id}/parts", "cursor", "abc", NEXT + "1 to 10 digits, after an n when it pages "
     "from the newest"),
    ("/plans", "cursor", "abc", NEXT + "1 to 10 digits"),
    ("/tools/x/fleet", "cursor", "z", NEXT + "1 to 10 digits, after an n when it pages from "
     "the newest"),  # its order=newest (a year's plant: the fleet's plans first)
    ("/tools/x/fleet/imported", "cursor", "!!", NEXT + "1 to 1200 letters, digits, _ or -"),
    ("/plans/{id}/models/versions", "operation", "a\x00", "must not contain NUL characters"),
    ("/plans/{id}/parts", "limit", "0", "must be at least 1"),
    ("/plans", "limit", "a", "must be a whole number"),
    ("/plans/{id}/parts", "order", "sideways", "must be one of 'oldest' or 'newest'"),
]  # fmt: skip


@pytest.mark.parametrize(("path", "name", "value", "allowed"), QUERIES)
def test_a_refused_query_parameter_is_said_in_words_not_a_pattern(
    service, path, name, value, allowed
):
    client, keys, plan = service
    r = _call(client, keys["viewer"], "GET", path.format(id=plan["id"]), params={name: value})
    assert r.status_code == 422, r.text
    _assert_worded(r.json(), name, value, allowed)


def test_a_refused_path_parameter_is_said_in_words(service):
    client, keys, _ = service
    r = _call(client, keys["viewer"], "GET", "/tools/a%00b")
    assert r.status_code == 422, r.text
    _assert_worded(r.json(), "name", "a\x00b", "must not contain NUL characters")


def _patterns(item: Any, where: str = "") -> list[tuple[str, str]]:
    """Every ``pattern`` of the OpenAPI document but a header's, with where it is."""
    if isinstance(item, list):
        return [p for i, x in enumerate(item) for p in _patterns(x, f"{where}[{i}]")]
    if not isinstance(item, dict) or item.get("in") == "header":
        return []
    found = [(where, item["pattern"])] if isinstance(item.get("pattern"), str) else []
    return found + [p for k, v in item.items() for p in _patterns(v, f"{where}.{k}")]


def test_every_pattern_of_the_document_is_declared_in_words(service):
    client, _, _ = service
    document = client.get("/api/v1/openapi.json")
    if document.status_code != 200:
        document = client.get("/openapi.json")
    patterns = _patterns(document.json())
    assert patterns  # the cursors, a tool's name, the blank-text check
    assert [(w, p) for w, p in patterns if p not in PATTERN_WORDS] == []


def test_parse_report_words_its_error_as_the_service_does():
    reading = {"force_N": {"value": 1565.0, "uncertainty": 12.0}}
    body = {
        "serial": "P-1",
        "setpoint_version": 1,
        "operations": [{"name": "rough-od", "measurements": reading}],
    }
    body = _changed(body, (*FORCE, "uncertainty"), 2000.0)
    with pytest.raises(InputError) as err:
        parse_report(body)
    assert (err.value.field, err.value.reason) == (
        f"{FORCE_FIELD}.uncertainty",
        "must be less than the value 1565",
    )


def test_a_duplicate_serial_s_409_names_the_stored_part(service):
    client, keys, plan = service
    body = report_at("W-DUP", plan)
    first = _call(client, keys["mes"], "POST", f"/plans/{plan['id']}/parts", json=body)
    assert first.status_code == 201, first.text
    again = _call(client, keys["mes"], "POST", f"/plans/{plan['id']}/parts", json=body)
    assert again.status_code == 409, again.text
    problem = again.json()
    stored = _call(client, keys["viewer"], "GET", f"/plans/{plan['id']}/parts/{problem['part_id']}")
    assert problem["part_id"] == first.json()["part_id"] == stored.json()["part_id"]
    assert (problem["field"], problem["value"]) == ("serial", "W-DUP")
    assert f"part {problem['part_id']}, received " in problem["detail"]
    assert not PYDANTIC.search(problem["detail"])
