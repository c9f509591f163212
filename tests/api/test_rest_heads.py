"""Bounded request heads (``api/rest/heads.py``): a 64 MB header field was answered 200 after
8.8 s with the server 135 MB larger, 100 000 header fields were answered too, and a URL over
64 KiB got uvicorn's plain-text 400. Now 431 or 414 problem+json at 32 KiB, before the app.

Raw sockets against a real ``rcb serve`` (httptools), and the protocol on its own for a refusal
that waits for the answer before it on the connection (HTTP/1.1 pipelining).
"""

from __future__ import annotations

import asyncio
import json
import re
import socket
import time
from pathlib import Path
from typing import Any

import pytest
import uvicorn
from uvicorn.server import ServerState

from api.rest.heads import MAX_HEAD_BYTES, HeadLimit

HEALTH = b"GET /api/v1/health HTTP/1.1\r\nHost: test\r\n"


def _exchange(port: int, raw: bytes, chunk: int = 1 << 16) -> bytes:
    """Send ``raw`` (until the server stops reading) and read the answer to the end."""
    with socket.create_connection(("127.0.0.1", port), timeout=30) as s:
        try:
            for start in range(0, len(raw), chunk):
                s.sendall(raw[start : start + chunk])
        except OSError:  # the server closed the connection: its answer is in
            pass
        out = b""
        while block := s.recv(1 << 16):
            out += block
    return out


def _answers(raw: bytes) -> list[tuple[int, dict[str, str], bytes]]:
    """The HTTP responses in ``raw``: status, headers (lower-case names) and body."""
    out = []
    while raw:
        head, _, rest = raw.partition(b"\r\n\r\n")
        lines = head.decode("latin-1").split("\r\n")
        headers = dict(line.lower().split(": ", 1) for line in lines[1:])
        size = int(headers["content-length"])
        out.append((int(lines[0].split()[1]), headers, rest[:size]))
        raw = rest[size:]
    return out


def _problem(raw: bytes, status: int, field: str) -> dict[str, Any]:
    [(got, headers, body)] = _answers(raw)
    assert got == status, raw[:500]
    assert headers["content-type"] == "application/problem+json"
    assert headers["connection"] == "close"
    problem: dict[str, Any] = json.loads(body)
    assert (problem["status"], problem["field"]) == (status, field), problem
    return problem


def _rss_kib(pid: int) -> int:
    status = Path(f"/proc/{pid}/status").read_text()
    return int(next(line for line in status.splitlines() if line.startswith("VmRSS")).split()[1])


def test_a_64_mb_header_field_is_431_at_once(sqlite_server):
    pid = sqlite_server.process.pid  # one worker: the server is this process
    before = _rss_kib(pid)
    started = time.monotonic()
    raw = _exchange(sqlite_server.port, HEALTH + b"X-Big: " + b"a" * (64 << 20) + b"\r\n\r\n")
    took = time.monotonic() - started
    problem = _problem(raw, 431, "X-Big")
    assert problem["code"] == "header_fields_too_large"
    assert problem["instance"] == "/api/v1/health"
    assert f"may have at most {MAX_HEAD_BYTES}" in problem["detail"]
    assert took < 5.0, took  # was 8.8 s, and answered 200
    assert _rss_kib(pid) - before < 16 * 1024  # was +135 MB


def test_many_header_fields_are_431_naming_headers(sqlite_server):
    fields = b"".join(b"X-%d: 1\r\n" % i for i in range(100_000))
    problem = _problem(_exchange(sqlite_server.port, HEALTH + fields + b"\r\n"), 431, "headers")
    # the head's first 32 KiB: the request line, Host, then about 3 000 of the 100 000
    fields_read = int(problem["detail"].split(" after ")[1].split()[0])
    assert 2_500 < fields_read < 4_000, problem["detail"]


def test_a_long_url_is_414_problem_json(sqlite_server):
    line = b"GET /api/v1/health?limit=" + b"9" * 70_000 + b" HTTP/1.1\r\nHost: test\r\n\r\n"
    problem = _problem(_exchange(sqlite_server.port, line), 414, "url")
    assert problem["code"] == "uri_too_long"
    assert problem["instance"] == "/api/v1/health"  # the path, not the 70 kB query


def _one_response(s: socket.socket) -> bytes:
    """One whole response off a kept-alive connection: its head, then Content-Length bytes
    (a response may arrive in more than one read, or two in one)."""
    data = b""
    while b"\r\n\r\n" not in data:
        block = s.recv(1 << 16)
        assert block, data
        data += block
    head, _, body = data.partition(b"\r\n\r\n")
    length = int(re.search(rb"(?i)content-length: *([0-9]+)", head).group(1))
    while len(body) < length:
        block = s.recv(1 << 16)
        assert block, body
        body += block
    assert len(body) == length, body  # nothing of the next response read
    return head + b"\r\n\r\n" + body


def test_a_head_under_the_limit_is_served_and_the_limit_is_per_request(sqlite_server):
    """A 30 KiB header field is answered; on a kept-alive connection the next request's head
    is counted from its own start (two heads of 30 KiB pass), and a third over it is 431."""
    fine = HEALTH + b"X-Fill: " + b"f" * (30 << 10) + b"\r\n\r\n"
    over = HEALTH + b"X-Fill: " + b"f" * (MAX_HEAD_BYTES + 1) + b"\r\n\r\n"
    with socket.create_connection(("127.0.0.1", sqlite_server.port), timeout=30) as s:
        for _ in range(2):
            s.sendall(fine)
            answer = _one_response(s)
            assert answer.startswith(b"HTTP/1.1 200 "), answer
        s.sendall(over)
        out = b""
        while block := s.recv(1 << 16):
            out += block
    _problem(out, 431, "X-Fill")


def test_a_refusal_waits_for_the_answer_in_progress():
    """HTTP/1.1 pipelining: a request, then a head over the limit sent behind it before its
    answer: the answer is sent whole, then the 431, then the connection is closed."""
    go: list[asyncio.Event] = []
    seen: list[str] = []

    async def app(scope: dict[str, Any], receive: Any, send: Any) -> None:
        seen.append(scope["path"])
        await go[0].wait()
        length = [(b"content-length", b"4")]
        await send({"type": "http.response.start", "status": 200, "headers": length})
        await send({"type": "http.response.body", "body": b"slow"})

    async def run() -> bytes:
        go.append(asyncio.Event())
        config = uvicorn.Config(app, lifespan="off", log_level="warning")
        config.load()
        state = ServerState()
        server = await asyncio.get_running_loop().create_server(
            lambda: HeadLimit(config=config, server_state=state, app_state={}), "127.0.0.1", 0
        )
        port = server.sockets[0].getsockname()[1]
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        writer.write(b"GET /slow HTTP/1.1\r\nHost: t\r\n\r\n")
        writer.write(b"GET /next HTTP/1.1\r\nHost: t\r\nX-Big: " + b"b" * 100_000 + b"\r\n\r\n")
        await writer.drain()
        try:  # nothing is answered while the first request is being served
            early = await asyncio.wait_for(reader.read(1 << 16), 0.5)
        except TimeoutError:
            early = b""
        assert early == b""
        assert seen == ["/slow"]  # the refused request never reached the app
        go[0].set()
        out = await asyncio.wait_for(reader.read(), 10)
        writer.close()
        server.close()
        return out

    answers = _answers(asyncio.run(run()))
    assert [(status, body[:4]) for status, _, body in answers] == [(200, b"slow"), (431, b'{"ty')]
    assert json.loads(answers[1][2])["field"] == "X-Big"
    assert seen == ["/slow"]


@pytest.mark.parametrize(
    "head",
    [
        HEALTH + b"X-Bad: a\x00b\r\n\r\n",  # a NUL in a field's value
        HEALTH + b"Bad Name: 1\r\n\r\n",  # a space in a field's name
        b"POST /api/v1/health HTTP/1.1\r\nHost: t\r\nContent-Length: abc\r\n\r\n",
        b"POST /api/v1/health HTTP/1.1\r\nHost: t\r\nContent-Length: 1\r\n"
        b"Content-Length: 2\r\n\r\n",
        b"POST /api/v1/health HTTP/1.1\r\nHost: t\r\nContent-Length: 1\r\n"
        b"Transfer-Encoding: chunked\r\n\r\n",
    ],
    ids=[
        "nul-in-value",
        "space-in-name",
        "length-not-a-number",
        "two-lengths",
        "length-and-chunked",
    ],
)
def test_a_request_the_parser_refuses_is_400_problem_json(sqlite_server, head):
    """uvicorn answered these ``400 text/plain Invalid HTTP request received.``"""
    problem = _problem(_exchange(sqlite_server.port, head), 400, "request")
    assert problem["code"] == "malformed_request"
    assert problem["type"] == "urn:rcb-supervisor:problem:malformed_request"
    assert problem["detail"].startswith("the request is not valid HTTP/1.1: ")
    assert problem["detail"] != "the request is not valid HTTP/1.1: "  # the parser's reason
    assert "Invalid HTTP request received" not in problem["detail"], problem
