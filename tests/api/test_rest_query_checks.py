"""A year of history, reviewed: the parts list pages from the newest as ``/history`` does, and
a query parameter a route does not take is refused, naming it, where it was ignored.

Through a real ``rcb serve`` on SQLite and PostgreSQL.
"""

from __future__ import annotations

from typing import Any

import httpx
import pytest
from test_service import BODY

from conftest import report_at

PARTS = 5


@pytest.fixture(scope="module")
def plan(server) -> dict[str, Any]:
    """A plan with :data:`PARTS` parts, ``P0`` to ``P4``, and their ids oldest first."""
    with server.client("engineer") as c:
        plan_id = c.post("/plans", json=BODY, params={"strategy": "ivester"}).json()["id"]
        setpoints = c.get(f"/plans/{plan_id}/setpoints").json()
        ids = []
        for i in range(PARTS):
            setpoints = c.post(
                f"/plans/{plan_id}/parts",
                json=report_at(f"P{i}", setpoints),
                headers={"Idempotency-Key": f"q-{plan_id}-{i}"},
            ).json()
            ids.append(setpoints["part_id"])
    return {"id": plan_id, "part_ids": ids}


def _page(c: httpx.Client, url: str, **params: Any) -> tuple[list[str], str | None]:
    r = c.get(url, params=params)
    assert r.status_code == 200, r.text
    return [p["serial"] for p in r.json()["items"]], r.json()["next_cursor"]


def _problem(r: httpx.Response, status: int, field: str) -> dict[str, Any]:
    assert r.status_code == status, r.text
    assert r.headers["content-type"] == "application/problem+json"
    body: dict[str, Any] = r.json()
    assert body["field"] == field, body
    return body


def test_parts_page_from_the_newest_and_back(server, plan):
    url = f"/plans/{plan['id']}/parts"
    ids = plan["part_ids"]
    with server.client("viewer") as c:
        # the review's request: it answered P0, the oldest
        assert _page(c, url, order="newest", limit=1) == (["P4"], f"n{ids[4]}")
        pages, cursor = [], None
        while True:
            params = {"order": "newest", "limit": 2, **({"cursor": cursor} if cursor else {})}
            serials, cursor = _page(c, url, **params)
            pages.append(serials)
            if cursor is None:
                break
        assert pages == [["P3", "P4"], ["P1", "P2"], ["P0"]]  # oldest first within a page
        # oldest stays the default, and its cursors are as before (a part's id)
        assert _page(c, url, limit=2) == (["P0", "P1"], str(ids[1]))
        assert _page(c, url, limit=2, order="oldest", cursor=str(ids[1])) == (
            ["P2", "P3"],
            str(ids[3]),
        )
        assert _page(c, url, order="newest", limit=50) == ([f"P{i}" for i in range(PARTS)], None)


def test_parts_since_a_time_in_either_order(server, plan):
    """``since``, as ``rcb parts --since`` takes it: from the first part received then on,
    sent again with each cursor; a time that is not one is a 422 naming ``since``."""
    url = f"/plans/{plan['id']}/parts"
    with server.client("viewer") as c:
        stamps = [p["received_at"] for p in c.get(url).json()["items"]]
        since = stamps[2]  # P2's own time, as the list shows it (ISO 8601, UTC, "Z")
        first, cursor = _page(c, url, since=since, limit=2)
        assert first == ["P2", "P3"]
        assert _page(c, url, since=since, limit=2, cursor=cursor) == (["P4"], None)
        newest, cursor = _page(c, url, since=since, limit=2, order="newest")
        assert newest == ["P3", "P4"]
        assert _page(c, url, since=since, limit=2, order="newest", cursor=cursor) == (["P2"], None)
        assert _page(c, url, since="2999-01-01") == ([], None)
        assert _page(c, url, since="2000-01-01T01:00:00+01:00")[0] == [f"P{i}" for i in range(5)]
        for bad, why in [
            ("yesterday", "expected an ISO 8601 date or time"),
            ("7d", "expected an ISO 8601 date or time"),  # an age is the CLI's alone
            ("1", "expected an ISO 8601 date or time"),  # not taken as a Unix time
            ("9999-12-31T23:59:59-05:00", "outside the years 1 to 9999 in UTC"),
            ("0001-01-01T00:00:00+05:00", "outside the years 1 to 9999 in UTC"),
        ]:
            body = _problem(c.get(url, params={"since": bad}), 422, "since")
            assert body["value"] == bad and why in body["detail"], body
        _problem(c.get(url, params={"since": "2" * 41}), 422, "since")


def test_a_cursor_of_one_order_is_refused_in_the_other(server, plan):
    url = f"/plans/{plan['id']}/parts"
    with server.client("viewer") as c:
        _, backward = _page(c, url, order="newest", limit=2)
        _, forward = _page(c, url, limit=2)
        r = c.get(url, params={"cursor": backward, "limit": 2})  # order=oldest by default
        body = _problem(r, 422, "cursor")
        assert body["value"] == backward
        assert "continues order=newest: send it with order=newest" in body["detail"]
        r = c.get(url, params={"cursor": forward, "order": "newest"})
        body = _problem(r, 422, "cursor")
        assert "continues order=oldest: send it with order=oldest" in body["detail"]
        for bad in ("x", "n", "nn3", "n-3", "3n", "n99999999999"):
            _problem(c.get(url, params={"cursor": bad, "order": "newest"}), 422, "cursor")
        _problem(c.get(url, params={"order": "sideways"}), 422, "order")


@pytest.mark.parametrize(
    ("path", "params", "field", "known"),
    [
        ("/plans", {"limitt": "5"}, "limitt", "cursor, limit"),
        ("/plans/{plan}/parts", {"sinse": "2026-01-01"}, "sinse", "cursor, limit, order, since"),
        ("/plans/{plan}/history", {"limit": "2", "Order": "newest"}, "Order", None),
        ("/plans/{plan}", {"verbose": "1"}, "verbose", "none"),
    ],
)
def test_an_unknown_query_parameter_is_named(server, plan, path, params, field, known):
    url = path.replace("{plan}", str(plan["id"]))
    with server.client("viewer") as c:
        body = _problem(c.get(url, params=params), 422, field)
    assert body["code"] == "invalid"
    assert body["value"] == params[field]
    assert body["detail"].startswith(f"{field}: unknown query parameter; known: ")
    if known is not None:
        assert body["detail"] == f"{field}: unknown query parameter; known: {known}"
    # the reason alone, as every 422's errors say it (the field and value are their own)
    reason = body["detail"].removeprefix(f"{field}: ")
    assert body["errors"] == [{"field": field, "message": reason, "value": params[field]}]


def test_a_write_is_refused_before_anything_is_stored(server, plan):
    """``POST /plans?strategy=learn&alhpa=0.1`` (a typo of a setting): 422, no plan stored; the
    settings' own query parameters (a dependency's) are known."""
    renamed = {**BODY, "name": "query typo"}
    with server.client("engineer") as c:
        before = c.get("/plans", params={"limit": 500}).json()["plans"]
        r = c.post("/plans", json=renamed, params={"strategy": "learn", "alhpa": "0.1"})
        body = _problem(r, 422, "alhpa")
        assert "alpha" in body["detail"].split("known: ")[1].split(", ")
        assert c.get("/plans", params={"limit": 500}).json()["plans"] == before
        r = c.post("/plans", json=renamed, params={"strategy": "learn", "alpha": "0.1"})
        assert r.status_code == 201, r.text


def test_health_takes_no_input_and_answers_any_query(server):
    """A liveness probe's cache-busting query (``?t=...``): health takes no input, declares no
    422 in the OpenAPI document, and answers as before."""
    r = httpx.get(f"{server.base}/health", params={"t": "1733140000"})
    assert (r.status_code, r.json()) == (200, {"status": "ok"})


def test_known_parameters_still_work_and_repeats_are_still_400(server, plan):
    with server.client("viewer") as c:
        r = c.get("/plans", params={"limit": 1})
        assert r.status_code == 200 and len(r.json()["plans"]) == 1
        r = c.get("/plans", params=[("limit", "1"), ("limit", "2")])
        assert _problem(r, 400, "limit")["code"] == "repeated_parameter"
        # without a key, an unknown parameter is named all the same (it reads nothing)
    with server.client(None) as c:
        _problem(c.get("/plans", params={"limitt": "5"}), 422, "limitt")


def test_a_path_id_not_in_digits_is_named_once(server):
    """``errors[].message`` said ``plan_id = 'abc': must be ...``: the field and value twice."""
    with server.client("viewer") as c:
        body = _problem(c.get("/plans/abc"), 422, "plan_id")
    assert body["detail"] == "plan_id = 'abc': must be a whole number in digits 0-9"
    reason = "must be a whole number in digits 0-9"
    assert body["errors"] == [{"field": "plan_id", "message": reason, "value": "abc"}]
