"""Issue 29, item 7, against a real ``rcb serve`` (SQLite and PostgreSQL): one spelling each.

Look-alike serials (white space at an end, full-width forms, a decomposed accent) are stored as
the one part they name, so the second report is 409; invisible characters (zero-width space) in a
serial or a plan name are refused naming the field; a body must be UTF-8 JSON without a key twice;
a single-valued query parameter is given once; a path id is digits. Nothing refused is stored.
"""

from __future__ import annotations

import itertools
import json
import unicodedata

import pytest

from conftest import demo_body, report_at

PLAN = demo_body()
PROBLEM = "application/problem+json"
NFC = unicodedata.normalize("NFC", "SÉRIE-é")
NFD = unicodedata.normalize("NFD", "SÉRIE-é")
_keys = itertools.count()


def _report(server, plan, serial):
    body = report_at(serial, plan)
    with server.client("mes") as c:
        headers = {"Idempotency-Key": f"id-{next(_keys)}"}
        return c.post(f"/plans/{plan['id']}/parts", json=body, headers=headers)


def _raw(server, path, content, role="mes", params=None):
    headers = {"Idempotency-Key": f"raw-{next(_keys)}", "Content-Type": "application/json"}
    with server.client(role) as c:
        return c.post(path, content=content, headers=headers, params=params)


def _serials(server, plan):
    with server.client("viewer") as c:
        items = c.get(f"/plans/{plan['id']}/parts", params={"limit": 500}).json()["items"]
    return [p["serial"] for p in items]


def _plans(server):
    with server.client("viewer") as c:
        return [p["name"] for p in c.get("/plans").json()["plans"]]


def _problem(r, status, code, field):
    assert r.status_code == status, r.text
    assert r.headers["content-type"] == PROBLEM
    problem = r.json()
    assert (problem["code"], problem["field"]) == (code, field), problem
    return problem


@pytest.mark.parametrize(
    ("first", "second", "stored"),
    [
        ("GOOD-1", "GOOD-1 ", "GOOD-1"),
        ("  GOOD-2\u3000", "GOOD-2", "GOOD-2"),  # ideographic space
        ("GOOD-3", "ＧＯＯＤ-３", "GOOD-3"),  # full-width forms
        ("ＧＯＯＤ-４", "GOOD-4", "GOOD-4"),
        (NFC, NFD, NFC),
        (unicodedata.normalize("NFD", "ÅNGSTRÖM-1"), "ÅNGSTRÖM-2", None),  # two parts
    ],
    ids=[
        "trailing-space",
        "ideographic-space",
        "full-width",
        "full-width-first",
        "nfd",
        "distinct",
    ],
)
def test_a_look_alike_serial_is_the_same_part(server, plan, first, second, stored):
    r = _report(server, plan, first)
    assert r.status_code == 201, r.text
    assert r.json()["serial"] == unicodedata.normalize("NFKC", first).strip()
    before = _serials(server, plan)
    again = _report(server, plan, second)
    if stored is None:
        assert again.status_code == 201, again.text
        assert _serials(server, plan) == [*before, second]
        return
    _problem(again, 409, "conflict", "serial")
    assert _serials(server, plan) == before
    assert before.count(stored) == 1
    assert first not in before or first == stored


@pytest.mark.parametrize(
    ("serial", "char"),
    [
        ("GOOD\u200b-1", "U+200B"),  # zero-width space
        ("\ufeffGOOD-1", "U+FEFF"),  # byte order mark
        ("GOOD-1\u200d", "U+200D"),  # zero-width joiner, at the end (not trimmed)
        ("GO\u00adOD-1", "U+00AD"),  # soft hyphen
    ],
)
def test_an_invisible_character_in_a_serial_is_refused(server, plan, serial, char):
    before = _serials(server, plan)
    problem = _problem(_report(server, plan, serial), 422, "invalid", "serial")
    assert problem["value"] == serial
    assert char in problem["detail"] and "invisible" in problem["detail"]
    assert _serials(server, plan) == before


def test_plan_names_are_normalised_or_refused(server):
    with server.client("engineer") as c:
        refused = c.post("/plans", json={**PLAN, "name": "base\u200b"})
        problem = _problem(refused, 422, "invalid", "name")
        assert problem["value"] == "base\u200b" and "U+200B" in problem["detail"]
        created = c.post("/plans", json={**PLAN, "name": " ｂａｓｅ-id "})
        assert created.status_code == 201, created.text
    names = _plans(server)
    assert "base\u200b" not in names and "base-id" in names and " ｂａｓｅ-id " not in names


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-le", "utf-16-be", "utf-32"])
def test_a_body_that_is_not_utf8_is_400(server, plan, encoding):
    before = _serials(server, plan)
    content = json.dumps(report_at(f"U16-{encoding}", plan)).encode(encoding)
    r = _raw(server, f"/plans/{plan['id']}/parts", content)
    problem = _problem(r, 400, "body_not_utf8", "body")
    assert "UTF-8" in problem["detail"]
    assert _serials(server, plan) == before


def test_invalid_utf8_is_400(server, plan):
    content = json.dumps(report_at("LATIN-É", plan), ensure_ascii=False).encode("latin-1")
    problem = _problem(
        _raw(server, f"/plans/{plan['id']}/parts", content), 400, "body_not_utf8", "body"
    )
    assert "0xc9" in problem["detail"]


def test_a_key_given_twice_is_400_naming_it(server, plan):
    before = _serials(server, plan)
    body = json.dumps(report_at("DUP-2", plan))
    top = '{"serial": "DUP-1", ' + body[1:]
    problem = _problem(
        _raw(server, f"/plans/{plan['id']}/parts", top.encode()), 400, "duplicate_key", "serial"
    )
    assert "'serial'" in problem["detail"]
    force = body.index('"force_N"')
    nested = body[:force] + '"force_N": {"value": 1.0, "uncertainty": 0.1}, ' + body[force:]
    r = _raw(server, f"/plans/{plan['id']}/parts", nested.encode())
    _problem(r, 400, "duplicate_key", "force_N")
    assert _serials(server, plan) == before
    plan_body = '{"name": "dup", ' + json.dumps({**PLAN, "name": "dup-2"})[1:]
    _problem(
        _raw(server, "/plans", plan_body.encode(), role="engineer"), 400, "duplicate_key", "name"
    )
    assert "dup" not in _plans(server) and "dup-2" not in _plans(server)


def test_a_single_valued_query_parameter_given_twice_is_400(server, plan):
    names = _plans(server)
    body = json.dumps({**PLAN, "name": "repeated"}).encode()
    repeated = [("alpha", "0.2"), ("alpha", "0.3")]
    problem = _problem(
        _raw(server, "/plans", body, "engineer", repeated), 400, "repeated_parameter", "alpha"
    )
    assert problem["value"] == ["0.2", "0.3"]
    twice = [("floor", "force_N=1"), ("floor", "force_N=2")]
    problem = _problem(_raw(server, "/plans", body, "engineer", twice), 422, "invalid", "floor")
    assert "force_N is given twice" in problem["detail"]
    # a bad floor is named as sent (it was 'floors.force_N', a name the request does not have)
    for item, why in [
        ("force_N=-5", "force_N: must be a number >= 0"),
        ("force_N=nan", "force_N: must be a number >= 0"),
        ("foo=5", "foo: unknown quantity"),
        ("force_N=lots", "the value must be a number"),
    ]:
        r = _raw(server, "/plans", body, "engineer", [("floor", item)])
        problem = _problem(r, 422, "invalid", "floor")
        assert problem["value"] == item and why in problem["detail"], problem
    assert _plans(server) == names
    with server.client("viewer") as c:
        r = c.get(f"/plans/{plan['id']}/parts", params=[("limit", "1"), ("limit", "500")])
        _problem(r, 400, "repeated_parameter", "limit")
    both = [("floor", "force_N=1"), ("floor", "roughness_um=0.01")]  # repeatable: still taken
    r = _raw(server, "/plans", body, "engineer", both)
    assert r.status_code == 201, r.text


@pytest.mark.parametrize("raw", ["%201", "1%20", "+1", "%D9%A1", "1_0", "01x"])
def test_a_path_id_is_digits_only(server, plan, raw):
    with server.client("viewer") as c:
        assert c.get(f"/plans/{plan['id']}").status_code == 200
        problem = _problem(c.get(f"/plans/{raw}"), 422, "invalid", "plan_id")
        assert "digits" in problem["detail"]
        _problem(c.get(f"/plans/{raw}/setpoints"), 422, "invalid", "plan_id")
