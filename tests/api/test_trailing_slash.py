"""A path with a trailing slash is a 404 problem, not a redirect built from the Host header.

A new user's review: ``GET /api/v1/plans/`` answered 307 to ``http://HOST/api/v1/plans``, the
host as the request named it: behind the REST guide's proxy, a host the MES cannot reach. The
web view's ``/ui`` still leads to ``/ui/``, by a relative address. Through a real server.
"""

from __future__ import annotations

import httpx


def test_a_trailing_slash_is_a_404_problem_without_a_location(server):
    with server.client("engineer", headers={"Host": "rcb"}) as c:
        for method in ("GET", "POST"):
            r = c.request(method, "/plans/", json={} if method == "POST" else None)
            assert r.status_code == 404, (method, r.status_code, r.headers)
            assert "location" not in r.headers
            assert r.headers["content-type"] == "application/problem+json"
            assert r.json()["instance"] == "/api/v1/plans/"
        assert c.get("/plans").status_code == 200  # without it, as documented


def test_the_web_view_root_leads_to_its_page_by_a_relative_address(server):
    base = f"http://127.0.0.1:{server.port}"
    with httpx.Client(base_url=base, timeout=60.0, headers={"Host": "rcb"}) as c:
        r = c.get("/ui")
        assert (r.status_code, r.headers["location"]) == (307, "/ui/")
        assert c.get("/ui/").status_code == 303  # no cookie: the login form, as before
