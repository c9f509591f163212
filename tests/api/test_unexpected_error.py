"""An error no handler takes is a 500 problem, and the connection stays open for the next request.

An MES integrator's audit: after a 500 (a report the learner failed on), the next request on the
same keep-alive connection failed with "connection reset by peer": Starlette sent the 500 and
raised the error again, and uvicorn closed the connection after it without ``Connection:
close``. :class:`api.rest.unexpected.UnexpectedAsProblem` now answers it and ends the request.
Through uvicorn on 127.0.0.1: a raw socket for both requests (before, it read nothing at all:
the close reset the connection before the 500 was read), then ``httpx``.
"""

from __future__ import annotations

import logging
import socket
import threading
import time
from collections.abc import Iterator

import httpx
import pytest
import uvicorn

from api.rest.app import create_app

from live import free_port
from migrated import migrated


@pytest.fixture
def failing(tmp_path) -> Iterator[str]:
    """The service on a fresh database with one more route, which fails; its base URL."""
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    migrated(url)
    app = create_app(url)

    @app.post("/api/v1/fails")
    def fails() -> None:
        raise RuntimeError("a bug")

    port = free_port()
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="critical"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not server.started and time.monotonic() < deadline:
        time.sleep(0.05)
    assert server.started
    yield f"http://127.0.0.1:{port}/api/v1"
    server.should_exit = True
    thread.join(30)


def _on_one_socket(base: str, *requests: bytes) -> list[bytes]:
    """Each request's answer, sent one after the other on one connection (b"" once closed)."""
    port = int(base.split(":")[2].split("/")[0])
    answers = []
    with socket.create_connection(("127.0.0.1", port), timeout=30) as s:
        for request in requests:
            try:
                s.sendall(request)
                answers.append(s.recv(1 << 16))
            except OSError:  # reset by peer
                answers.append(b"")
    return answers


def test_the_connection_outlives_the_500(failing):
    fails = b"POST /api/v1/fails HTTP/1.1\r\nHost: t\r\nContent-Length: 2\r\n\r\n{}"
    health = b"GET /api/v1/health HTTP/1.1\r\nHost: t\r\n\r\n"
    failed, after = _on_one_socket(failing, fails, health)
    assert failed.startswith(b"HTTP/1.1 500 ")
    assert after.startswith(b"HTTP/1.1 200 ")  # was b"": the server had closed it


def test_a_500_is_problem_json_and_its_traceback_is_logged(failing, caplog):
    with caplog.at_level(logging.ERROR), httpx.Client(base_url=failing, timeout=30) as client:
        failed = client.post("/fails", json={})
        assert failed.status_code == 500
        assert failed.headers["content-type"] == "application/problem+json"
        assert failed.json()["detail"] == "internal error; nothing was stored"
        assert failed.headers.get("connection") != "close"
        assert client.get("/health").status_code == 200
    assert "RuntimeError: a bug" in caplog.text  # the traceback is logged for the operator
