"""A page asked for without a session is the page the sign-in comes back to (api.report.ui_login).

An engineer follows a link to a plan's page (from the MES, a mail, a bookmark) and signs in:
the view went to the plan list, and the plan asked for had to be found again. Now the sign-in
form carries ``next`` and goes there. ``next`` is only ever one of the view's own pages, so the
form cannot send a signed-in browser to another site (an open redirect): anything else is a 400
naming it, and no session is opened. Through a real ``rcb serve`` on each database.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from urllib.parse import quote

import httpx
import pytest
from test_ui_params import PLAN, _assert_refused, _ui

#: ``next`` values no sign-in may follow: other sites, API paths, pages with what they refuse.
FOREIGN = (
    "https://evil.example/ui/",
    "//evil.example/ui/",
    "/api/v1/plans",
    "/ui/../api/v1/plans",
    "/ui/plans/1?x=1",
    "/ui/plans/abc",
    "/ui/login",
    "/ui/" + "p" * 100,
    "<script>alert(1)</script>",
)


@pytest.fixture(scope="module")
def plan_id(server) -> int:
    with server.client("engineer") as c:
        r = c.post("/plans", json={**PLAN, "name": "return-after-sign-in"})
    assert r.status_code == 201, r.text
    return int(r.json()["id"])


def _client(server) -> httpx.Client:
    return httpx.Client(base_url=_ui(server), timeout=60.0, follow_redirects=False)


def _kept(r: httpx.Response) -> str | None:
    """The ``next`` the sign-in form carries (its hidden field), or None."""
    root = ET.fromstring(r.text.removeprefix("<!DOCTYPE html>\n"))
    field = root.find(".//form//input[@name='next']")
    return None if field is None else field.get("value")


def test_a_plan_page_asked_for_is_where_the_sign_in_goes(server, plan_id):
    page = f"/ui/plans/{plan_id}"
    with _client(server) as c:
        asked = c.get(f"/plans/{plan_id}")
        assert asked.status_code == 303
        assert asked.headers["location"] == f"/ui/login?next={quote(page, safe='')}"
        form = c.get(asked.headers["location"].removeprefix("/ui"))
        assert form.status_code == 200 and _kept(form) == page
        wrong = c.post("/login", data={"key": "rcb_not-a-key", "next": page})
        assert wrong.status_code == 401 and _kept(wrong) == page  # kept for the next try
        signed = c.post("/login", data={"key": server.keys["viewer"], "next": page})
        assert (signed.status_code, signed.headers["location"]) == (303, page)
        shown = c.get(page.removeprefix("/ui"))
    assert shown.status_code == 200 and "return-after-sign-in" in shown.text


def test_a_page_of_the_plan_list_is_kept_and_the_list_itself_needs_no_next(server, plan_id):
    with _client(server) as c:
        listed = c.get("/", params={"cursor": str(plan_id)})
        assert (
            listed.headers["location"]
            == f"/ui/login?next={quote('/ui/?cursor=', safe='')}{plan_id}"
        )
        home = c.get("/")
        assert home.headers["location"] == "/ui/login"  # where a sign-in goes anyway
        assert _kept(c.get("/login")) is None
        signed = c.post("/login", data={"key": server.keys["viewer"]})
    assert signed.headers["location"] == "/ui/"


@pytest.mark.parametrize("value", FOREIGN)
def test_a_next_that_is_not_a_page_of_the_view_is_refused(server, value):
    with _client(server) as c:
        form = c.get("/login", params={"next": value})
        post = c.post("/login", data={"key": server.keys["viewer"], "next": value})
    _assert_refused(form, "next", value, signed_in=False)
    _assert_refused(post, "next", value, signed_in=False)  # no cookie: no session opened
