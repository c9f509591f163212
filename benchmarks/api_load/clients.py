"""The MES clients: plans created over the API, reports posted in a closed loop."""

from __future__ import annotations

import http.client
import json
import socket
import threading
import time
import tomllib
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import urlsplit

import httpx

from benchmarks.api_load.config import PLAN_FILE, UNCERTAINTY, perf


def plan_body(name: str, ops: int) -> dict[str, Any]:
    """The demonstration part as JSON, with its first ``ops`` operations."""
    body = tomllib.loads(PLAN_FILE.read_text(encoding="utf-8"))
    body["name"] = name
    body["operations"] = body["operations"][:ops]
    return body


@dataclass
class View:
    """What one client knows of a plan: the setpoint version in force and its predictions."""

    plan_id: int
    version: int
    predicted: list[tuple[str, dict[str, Any]]]

    @classmethod
    def of(cls, plan_id: int, answer: dict[str, Any]) -> View:
        ops = [(op["name"], op["predicted"]) for op in answer["operations"]]
        return cls(plan_id, int(answer["setpoint_version"]), ops)

    def report(self, serial: str) -> dict[str, Any]:
        """A report of a part made with these setpoints: every quantity at its prediction."""
        return {
            "serial": serial,
            "setpoint_version": self.version,
            "operations": [
                {
                    "name": name,
                    "measurements": {
                        q: {"value": predicted[q]["value"], "uncertainty": u}
                        for q, u in UNCERTAINTY.items()
                    },
                }
                for name, predicted in self.predicted
            ],
        }


def create_plans(
    base: str, key: str, count: int, ops: int, prefix: str, threads: int
) -> list[dict[str, Any]]:
    """Create ``count`` plans over the API (in parallel), each answer in creation order."""

    def one(i: int) -> dict[str, Any]:
        with httpx.Client(headers={"Authorization": f"Bearer {key}"}, timeout=120.0) as c:
            r = c.post(f"{base}/plans", json=plan_body(f"{prefix}-{i}", ops))
        if r.status_code != 201:
            raise RuntimeError(f"POST /plans answered {r.status_code}: {r.text[:500]}")
        return dict(r.json())

    if count == 0:
        return []
    # the first plan alone: on an empty PostgreSQL database concurrent creations of plans on
    # the same machine and tools race to insert them and all but one are refused (409)
    first = one(0)
    with ThreadPoolExecutor(max_workers=max(1, min(threads, count))) as pool:
        return [first, *pool.map(one, range(1, count))]


@dataclass
class Sample:
    """One measured request."""

    start: float
    end: float
    status: int | str
    resolved: bool = False
    older_version: bool = False


class MesConnection:
    """One kept-alive HTTP/1.1 connection with the ``mes`` key (reopened after an error).

    ``http.client`` sends a request's headers and body in one write, so Nagle's algorithm and
    delayed ACKs cannot stall it; ``TCP_NODELAY`` is set all the same.
    """

    def __init__(self, base: str, key: str) -> None:
        parts = urlsplit(base)
        self.host, self.port, self.prefix = parts.hostname or "127.0.0.1", parts.port, parts.path
        self.headers = {"Authorization": f"Bearer {key}", "Content-Type": "application/json"}
        self.connection: http.client.HTTPConnection | None = None

    def post(self, path: str, body: dict[str, Any], key: str) -> tuple[int, bytes]:
        """POST ``body`` as JSON with an Idempotency-Key; (status, answer bytes)."""
        if self.connection is None:
            self.connection = http.client.HTTPConnection(self.host, self.port, timeout=120.0)
            self.connection.connect()
            self.connection.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        headers = {**self.headers, "Idempotency-Key": key}
        try:
            self.connection.request("POST", self.prefix + path, json.dumps(body), headers)
            answer = self.connection.getresponse()
            return answer.status, answer.read()
        except (OSError, http.client.HTTPException):
            self.close()
            raise

    def close(self) -> None:
        if self.connection is not None:
            self.connection.close()
            self.connection = None


@dataclass
class Client:
    """One MES client: a keep-alive connection and its plans, cycled through in turn."""

    index: int
    http: MesConnection
    warmup: View | None
    views: list[View]
    samples: list[Sample] = field(default_factory=list)
    warmup_reports: int = 0
    warmup_errors: Counter[str] = field(default_factory=Counter)


class Budget:
    """At most ``limit`` measured requests over all clients."""

    def __init__(self, limit: int) -> None:
        self.left = limit
        self.lock = threading.Lock()

    def take(self) -> bool:
        with self.lock:
            if self.left <= 0:
                return False
            self.left -= 1
            return True


def post_report(client: Client, view: View, serial: str) -> tuple[int | str, dict[str, Any]]:
    """Post one report; (status or exception name, answer JSON if 201)."""
    body = view.report(serial)
    try:
        status, answer = client.http.post(f"/plans/{view.plan_id}/parts", body, serial)
    except (OSError, http.client.HTTPException) as err:
        return err.__class__.__name__, {}
    return status, json.loads(answer) if status == 201 else {}


def run_client(
    client: Client,
    token: str,
    warmup_end: float,
    window_start: float,
    window_end: float,
    stop: threading.Event,
    budget: Budget,
) -> None:
    """The closed loop of one client: warm-up plan until ``warmup_end``, then its plans."""
    n = 0
    while client.warmup is not None and not stop.is_set() and perf() < warmup_end:
        n += 1
        status, answer = post_report(client, client.warmup, f"{token}-w{client.index}-{n}")
        if status == 201:
            client.warmup_reports += 1
            client.warmup = View.of(client.warmup.plan_id, answer)
        else:
            client.warmup_errors[str(status)] += 1
    while perf() < window_start and not stop.is_set():
        time.sleep(min(0.01, max(0.0, window_start - perf())))
    turn = 0
    while not stop.is_set() and perf() < window_end and budget.take():
        view = client.views[turn % len(client.views)]
        turn += 1
        n += 1
        t0 = perf()
        status, answer = post_report(client, view, f"{token}-c{client.index}-{n}")
        t1 = perf()
        sample = Sample(t0, t1, status)
        if status == 201:
            sample.resolved = any(u["action"] != "hold" for u in answer["updates"])
            new = View.of(view.plan_id, answer)
            sample.older_version = new.version > view.version + int(sample.resolved)
            client.views[(turn - 1) % len(client.views)] = new
        client.samples.append(sample)
