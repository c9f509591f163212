"""A created plan's 201 says where it is: ``Location: /api/v1/plans/{id}`` (RFC 9110 §15.3.2).

A new user's review (an MES integrator): no 201 had a ``Location``; the MES built the plan's
URL itself. A replay of the same key answers the same ``Location``. Through a real server.
"""

from __future__ import annotations

import httpx
from test_service import BODY


def test_a_created_plan_is_located_and_a_replay_locates_it_again(server):
    body = {**BODY, "name": "located"}
    key = {"Idempotency-Key": "located-1"}
    with server.client("engineer") as c:
        made = c.post("/plans", json=body, headers=key)
        assert made.status_code == 201, made.text
        where = made.headers["location"]
        assert where == f"/api/v1/plans/{made.json()['id']}"
        root = server.base.removesuffix("/api/v1")
        shown = httpx.get(root + where, headers=c.headers, timeout=60.0)
        assert shown.status_code == 200 and shown.json()["name"] == "located"
        again = c.post("/plans", json=body, headers=key)
        assert again.headers["idempotent-replayed"] == "true"
        assert (again.status_code, again.headers["location"]) == (201, where)
        taken = c.post("/plans", json=body)
        assert taken.status_code == 409 and "location" not in taken.headers
        document = c.get("/openapi.json").json()
    declared = document["paths"]["/api/v1/plans"]["post"]["responses"]["201"]["headers"]
    assert "Location" in declared
