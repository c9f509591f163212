"""HEAD is GET without the content (RFC 9110 §9.1, §9.3.2), against a real ``rcb serve``.

An MES integrator's load balancer and uptime probe sent ``HEAD /api/v1/health`` and got 405
(``Allow: GET``): the service was marked down. Every GET route now answers HEAD with the GET's
status and header fields and no content, through the same authentication and problems
(:mod:`api.rest.head_method`).
"""

from __future__ import annotations

import socket
from typing import Any

import httpx
import pytest
from sqlalchemy import select
from sqlalchemy.orm import Session
from test_service import BODY

from db import tables as t
from db.engine import make_engine

from conftest import renamed

#: Header fields that may differ between two answers to the same request.
_VARYING = {"date"}


@pytest.fixture(scope="module")
def plan_id(server) -> int:
    with server.client("engineer") as c:
        created = c.post("/plans", json=renamed(BODY), params={"strategy": "ivester"})
    assert created.status_code == 201, created.text
    plan: dict[str, Any] = created.json()
    return int(plan["id"])


def _headers(r: httpx.Response) -> dict[str, str]:
    return {name: value for name, value in r.headers.items() if name not in _VARYING}


def _same_but_content(get: httpx.Response, head: httpx.Response) -> None:
    """``head`` answers as ``get`` did: status and header fields, and no content."""
    assert head.status_code == get.status_code, (get.text, head.headers)
    assert _headers(head) == _headers(get)
    assert head.content == b""
    assert int(head.headers["content-length"]) == len(get.content) > 0


def _raw(server, request: bytes) -> bytes:
    """What the server sends for ``request`` (raw HTTP/1.1), read until it closes."""
    with socket.create_connection(("127.0.0.1", server.port), timeout=30) as sock:
        sock.sendall(request)
        chunks = []
        while chunk := sock.recv(65536):
            chunks.append(chunk)
    return b"".join(chunks)


def test_head_health_is_the_get_without_content(server):
    with server.client(role=None) as c:
        get, head = c.get("/health"), c.head("/health")
    _same_but_content(get, head)
    assert head.status_code == 200 and head.headers["content-type"] == "application/json"
    # on the wire: the HEAD's header fields, then at once the next answer on the connection
    sent = _raw(
        server,
        b"HEAD /api/v1/health HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n"
        b"GET /api/v1/health HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n",
    )
    first, _, rest = sent.partition(b"\r\n\r\n")
    assert first.startswith(b"HTTP/1.1 200 ")
    assert rest.startswith(b"HTTP/1.1 200 ") and rest.endswith(b'{"status":"ok"}')


@pytest.mark.parametrize(
    "path",
    [
        "/plans/{plan}",
        "/plans/{plan}/setpoints",
        "/plans/{plan}/history?limit=1",
        "/plans/{plan}/parts?order=newest",
        "/plans/{plan}/models",
        "/plans?limit=1",
        "/tools?limit=2",
    ],
)
def test_head_with_a_key_is_the_get_without_content(server, plan_id, path):
    url = path.format(plan=plan_id)
    with server.client("viewer") as c:
        get, head = c.get(url), c.head(url)
    assert get.status_code == 200, get.text
    _same_but_content(get, head)


def test_head_with_a_wrong_key_is_401_without_content(server, plan_id):
    with server.client(role=None, headers={"Authorization": "Bearer rcb_not-a-key"}) as c:
        get, head = c.get(f"/plans/{plan_id}"), c.head(f"/plans/{plan_id}")
    assert head.status_code == 401
    _same_but_content(get, head)
    assert head.headers["www-authenticate"] == "Bearer"
    assert head.headers["content-type"] == "application/problem+json"
    with server.client(role=None) as c:  # no key at all
        _same_but_content(c.get(f"/plans/{plan_id}"), c.head(f"/plans/{plan_id}"))


def test_head_answers_the_problems_of_the_get(server, plan_id):
    with server.client("viewer") as c:
        for url in (
            "/plans/999999",  # 404
            f"/plans/{plan_id}/history?order=newest&cursor=3",  # 422: a cursor of order=oldest
            f"/plans/{plan_id}?verbose=1",  # 422: an unknown query parameter
            "/no/such/path",  # 404
        ):
            get, head = c.get(url), c.head(url)
            assert get.status_code in (404, 422), get.text
            _same_but_content(get, head)


def test_head_on_a_path_without_get_stays_405(server, plan_id):
    url = f"/plans/{plan_id}/replan"
    with server.client("engineer") as c:
        head = c.head(url)
        assert head.status_code == 405 and head.headers["allow"] == "POST"
        _same_but_content(c.get(url), head)
        options = c.options("/health")  # OPTIONS is as it was: 405, no CORS
    assert options.status_code == 405 and options.headers["allow"] == "GET, HEAD"


def test_head_on_the_web_view(server):
    with httpx.Client(base_url=f"http://127.0.0.1:{server.port}/ui", timeout=60.0) as c:
        _same_but_content(c.get("/login"), c.head("/login"))
        home = c.head("/")  # no cookie: to the login form, as the GET
        assert (home.status_code, home.headers["location"]) == (303, "/ui/login")
        assert home.content == b""
        logout = c.head("/logout")
    assert logout.status_code == 405 and logout.headers["allow"] == "POST"


def test_a_head_refused_is_audited_as_head(server, plan_id):
    """The audit log named a HEAD's failure ``GET ...``: the app is handed a GET."""
    local = "127.0.0.5"  # an address of its own: its failures are counted apart
    transport = httpx.HTTPTransport(local_address=local)
    headers = {"Authorization": "Bearer rcb_not-a-key"}
    with httpx.Client(base_url=server.base, transport=transport, headers=headers) as c:
        assert c.head(f"/plans/{plan_id}/setpoints").status_code == 401
        assert c.get("/plans").status_code == 401
    engine = make_engine(server.url)
    with Session(engine) as session:
        rows = session.scalars(select(t.AuditEntry).where(t.AuditEntry.result == "unauthenticated"))
        actions = {r.action for r in rows if (r.detail or {}).get("client") == local}
    engine.dispose()
    assert actions == {"HEAD /api/v1/plans/{plan_id}/setpoints", "GET /api/v1/plans"}
