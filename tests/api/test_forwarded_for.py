"""Issue 33, item 2: the client address from a trusted proxy's ``X-Forwarded-For``.

Behind a reverse proxy every request comes from the proxy: without the header, one client's
wrong keys would spend the burst of every MES behind it (429 for all). ``rcb serve
--forwarded-allow-ips`` names the proxies whose header names the client (uvicorn's
ProxyHeadersMiddleware); a peer not named cannot pick its address by sending the header.
Real ``rcb serve`` processes; clients bind distinct loopback addresses (Linux routes all of
127.0.0.0/8 to the loopback).
"""

from __future__ import annotations

import subprocess
import time
from collections.abc import Callable

import httpx
import pytest

from api.services import throttle

from live import RCB, LiveServer

PROXY = "127.0.0.7"
OUTSIDER = "127.0.0.8"
WRONG = {"Authorization": "Bearer rcb_not-a-key"}


def _flood(server: LiveServer, peer: str, forwarded: list[str]) -> list[int]:
    """One wrong-key request per ``forwarded`` value, from ``peer``: the statuses."""
    transport = httpx.HTTPTransport(local_address=peer)
    with httpx.Client(base_url=server.base, transport=transport, timeout=30.0) as client:
        return [
            client.get("/plans", headers={**WRONG, "X-Forwarded-For": f}).status_code
            for f in forwarded
        ]


def _locked_out(server: LiveServer, peer: str, forwarded: Callable[[int], str]) -> None:
    """Wrong keys from ``peer`` with the ``forwarded(i)`` header, until a 429 (at most three
    bursts): the burst's failures are 401, then 429; the bucket refills at
    ``REFILL_PER_S`` while the flood runs (a loaded machine's flood of 60 took seconds, and
    the failures the refill allowed are 401 too), so no more than those are."""
    burst = throttle.BURST_FAILURES
    transport = httpx.HTTPTransport(local_address=peer)
    statuses: list[int] = []
    start = time.monotonic()
    with httpx.Client(base_url=server.base, transport=transport, timeout=30.0) as client:
        while 429 not in statuses and len(statuses) < 3 * burst:
            header = {**WRONG, "X-Forwarded-For": forwarded(len(statuses))}
            statuses.append(client.get("/plans", headers=header).status_code)
    refilled = int((time.monotonic() - start) * throttle.REFILL_PER_S) + 1
    assert statuses[:burst] == [401] * burst, statuses
    assert statuses[-1] == 429 and set(statuses) == {401, 429}, statuses
    assert statuses.count(401) <= burst + refilled, (len(statuses), refilled)


@pytest.fixture
def behind_proxy(tmp_path):
    server = LiveServer(
        f"sqlite:///{tmp_path / 'rcb.db'}",
        tmp_path / "serve.log",
        args=("--forwarded-allow-ips", PROXY),
    )
    server.start()
    yield server
    server.stop()


def test_a_trusted_proxy_names_each_client_and_each_has_its_own_burst(behind_proxy):
    _locked_out(behind_proxy, PROXY, lambda i: "10.1.1.1")
    # another MES behind the same proxy is not locked out by the first one's wrong keys
    assert _flood(behind_proxy, PROXY, ["10.1.1.2"]) == [401]


def test_a_peer_not_trusted_cannot_choose_its_address(behind_proxy):
    _locked_out(behind_proxy, OUTSIDER, lambda i: f"10.2.{i // 250}.{i % 250 + 1}")


def test_none_trusts_no_peer_not_even_this_host(tmp_path):
    server = LiveServer(
        f"sqlite:///{tmp_path / 'rcb.db'}",
        tmp_path / "serve.log",
        args=("--forwarded-allow-ips", "none"),
    )
    server.start()
    try:  # uvicorn's default would trust this host's header
        _locked_out(server, "127.0.0.1", lambda i: f"10.3.{i // 250}.{i % 250 + 1}")
    finally:
        server.stop()


def test_by_default_a_process_on_this_host_cannot_choose_its_address(tmp_path):
    """A lockout review: the default was uvicorn's (this host is a proxy), so any local
    process sent a new X-Forwarded-For per request and never met the wrong-key limit."""
    server = LiveServer(f"sqlite:///{tmp_path / 'rcb.db'}", tmp_path / "serve.log")
    server.start()
    try:
        _locked_out(server, "127.0.0.1", lambda i: f"10.4.{i // 250}.{i % 250 + 1}")
    finally:
        server.stop()


@pytest.mark.parametrize(
    ("args", "env", "needles"),
    [
        (["--forwarded-allow-ips", "10.0.0.300"], {}, ["--forwarded-allow-ips", "'10.0.0.300'"]),
        (["--forwarded-allow-ips", ""], {}, ["--forwarded-allow-ips", "'*' or 'none'"]),
        (
            [],
            {"RCB_FORWARDED_ALLOW_IPS": "proxy.local"},
            ["RCB_FORWARDED_ALLOW_IPS", "proxy.local"],
        ),
    ],
)
def test_a_malformed_proxy_list_is_refused_before_serving(tmp_path, args, env, needles):
    command = [str(RCB), "serve", "--db", f"sqlite:///{tmp_path / 'rcb.db'}", "--port", "1", *args]
    done = subprocess.run(
        command, capture_output=True, text=True, timeout=60, env={"PATH": "/usr/bin:/bin", **env}
    )
    assert done.returncode == 2, (done.returncode, done.stdout, done.stderr)
    line = done.stderr.strip()
    assert "\n" not in line and "Traceback" not in line, done.stderr
    for needle in needles:
        assert needle in line, (needle, line)
