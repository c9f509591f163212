"""Load benchmark of the REST service: concurrent MES clients reporting parts (run on demand).

What it measures. For every configuration (backend x ``--workers``), on a fresh database:

1. the script starts its own ``rcb serve --db URL --workers N --no-access-log`` on 127.0.0.1
   and a free port (a SQLite file in a temporary directory, or a new PostgreSQL database
   ``rcb_bench_<random>`` dropped at the end); the API keys come from ``rcb keys create``;
2. it creates ``--plans K`` plans over the API (``POST /api/v1/plans``, engineer key) from
   ``examples/ivester_demo_part.toml``: all six operations, or only the first (``--ops 1``, one
   operation, i.e. a sixth of the measurements, band updates and LPs of a report);
3. ``--clients N`` client threads, each with its own keep-alive connection (the standard
   library's ``http.client``, lighter than httpx: the load generator shares the CPUs with the
   server) and the ``mes`` key, post part reports (``POST /api/v1/plans/{id}/parts`` with
   a unique ``Idempotency-Key`` and serial) back to back: a closed loop, each client sends its
   next report when the previous answer arrives. A report carries, as in the REST tests, the
   predicted value of every quantity at the setpoints the client last received for that plan
   (the creation answer, then each report's answer) with Table 5's uncertainties;
4. first ``--warmup`` seconds on separate warm-up plans (one per client, not counted): every
   worker that holds a connection loads its first plans and warms its caches there, so the
   measured plans start their learning in the window;
5. then the measured window of ``--duration`` seconds (the issue: 30 s), bounded too by
   ``--max-requests``. Counted: the reports *started* in the window; throughput = successful
   reports / (end of the last counted report - start of the window); latency = the client's
   wall time from sending the request to the whole answer read (HTTP, auth, the transaction
   with RCB and any re-solve, JSON), percentiles over the successful reports (p50/p95/p99,
   ``statistics.quantiles`` inclusive). Errors are counted by HTTP status or exception.

Plans and clients. A plan's reports are serialised by the database (row lock on the plan),
so one plan admits one report at a time. With ``--plans K >= --clients N`` client ``c`` owns
plans ``c, c+N, ...`` and cycles through them (no two clients share a plan); with ``K < N``
client ``c`` reports to plan ``c mod K`` and ``N/K`` clients contend for each plan (a report
made with a setpoint version another client has already superseded is applied at its own
version, which costs the server a few more queries for that version's setpoints).

Closed loop. Each client waits for its answer, so the reports in flight equal the clients
and, by Little's law, mean latency = clients / throughput (printed as "in flight"). The two
targets together therefore hold only at about 200 x 0.020 = 4 reports in flight or fewer: 16
clients at 200 reports/s wait 80 ms on average however fast each report is. Run a small
``--clients`` for the latency target and a larger one for the throughput ceiling.

Learning and converged reports. A report re-optimises the plan (six LPs, or one) only when
a band moves. With measurements equal to the predictions, each band shrinks by a quarter of
its margin per report until it reaches the measurement uncertainty: on the demonstration part
the first ~23 reports of a plan move a band and re-solve, later ones only hold (no LP). The
share of re-solving reports is printed ("re-solved"); more plans (``--plans``) give more
learning reports, fewer give a mostly converged shop.

CPU. Client and server share this machine's CPUs: the load generator is kept light (threads
blocked on sockets, one JSON body built per request), and the script prints the CPU seconds
used during the window (``/proc``) by the server's workers (per worker, with the keep-alive
connections each one accepted: one worker often takes most of them), by the PostgreSQL
backends of the benchmark database (those alive at the end of the window; the number of
sessions opened during the window is printed too), by the load generator itself, by other
processes and by the whole host, plus the CPU cost per report. Other work on the host skews
the figures: the summary's "other load" column is its share of the host's CPU during the
window, and ``--quiet-wait S`` waits up to S seconds for an idle host before each run.

Several workers and TCP_NODELAY. With ``--workers`` > 1 uvicorn (0.54 here) creates the
listening socket with ``proto`` 0, so asyncio never sets ``TCP_NODELAY`` on the accepted
connections, and every answer on a keep-alive connection waits for the client's delayed ACK
(about 40 ms on Linux) between its header and body writes (Kludex/uvicorn issue #3149;
``--workers 1`` is not affected). ``--nodelay-fix`` starts the same ``rcb serve`` command
through a launcher in this script that re-creates uvicorn's listener with ``IPPROTO_TCP``
(the application is unchanged), to measure the service without that delay; the output and
the summary ("listener": stock or patched) say which was used.

Targets from the issue (PostgreSQL, on this 2-core machine): p50 <= 20 ms and >= 200
reports/s; the script says for every PostgreSQL configuration whether they are met and exits
0 either way.

Usage (from the repository root)::

    .venv/bin/python benchmarks/api_load.py [--backend sqlite|postgres|both] [--workers 2,4]
        [--clients 16] [--plans K] [--ops 6|1] [--duration 30] [--warmup 3]
        [--max-requests 200000] [--postgres-url URL] [--nodelay-fix] [--quiet-wait S]
        [--markdown]

How long it takes: per configuration the duration and warm-up, plus about 15 s to create the
database, the keys and the plans and to start and stop the server (``--plans 400`` adds about
15 s more) and any ``--quiet-wait``; the default run (both backends x 2 worker counts) takes
about three and a half minutes.
"""

from __future__ import annotations

import argparse
import http.client
import json
import os
import platform
import secrets
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import tomllib
from collections import Counter
from collections.abc import Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import httpx

ROOT = Path(__file__).resolve().parents[1]
PLAN_FILE = ROOT / "examples" / "ivester_demo_part.toml"
RCB = Path(sys.executable).with_name("rcb")
PREFIX = "/api/v1"
#: Table 5's measured +- columns, as in tests/test_rest_api.py.
UNCERTAINTY = {"force_N": 3.0, "roughness_um": 0.05}
DEFAULT_POSTGRES = (
    os.environ.get("RCB_TEST_POSTGRES_URL") or "postgresql+psycopg://postgres@127.0.0.1:5432/test"
)
#: The issue's targets (PostgreSQL).
TARGET_P50_MS = 20.0
TARGET_RPS = 200.0
CLK_TCK = os.sysconf("SC_CLK_TCK")

perf = time.perf_counter


# --------------------------------------------------------------------------- CPU accounting


def _stat_fields(pid: int) -> list[str] | None:
    try:
        raw = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return raw.rpartition(")")[2].split()  # [state, ppid, ..., utime (11), stime (12), ...]


def process_cpu_s(pid: int) -> float | None:
    """User + system CPU seconds of one process (None if it is gone)."""
    fields = _stat_fields(pid)
    return None if fields is None else (int(fields[11]) + int(fields[12])) / CLK_TCK


def descendants(pid: int) -> list[int]:
    """Every live descendant of ``pid`` (children, grandchildren, ...)."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            fields = _stat_fields(int(entry.name))
            if fields is not None:
                children.setdefault(int(fields[1]), []).append(int(entry.name))
    found, todo = [], [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.append(child)
            todo.append(child)
    return sorted(found)


def host_cpu_s() -> tuple[float, float]:
    """(busy, total) CPU seconds of the whole host since boot, from /proc/stat."""
    values = [int(v) for v in Path("/proc/stat").read_text().splitlines()[0].split()[1:]]
    total = sum(values[:8])  # user nice system idle iowait irq softirq steal
    return (total - values[3] - values[4]) / CLK_TCK, total / CLK_TCK


def connections_per_process(pids: Sequence[int], port: int) -> list[int]:
    """Established TCP connections to local ``port`` held by each of ``pids`` (IPv4)."""
    inodes: set[str] = set()
    for line in Path("/proc/net/tcp").read_text().splitlines()[1:]:
        cols = line.split()
        if cols[3] == "01" and int(cols[1].rpartition(":")[2], 16) == port:
            inodes.add(cols[9])
    counts = []
    for pid in pids:
        n = 0
        try:
            for fd in Path(f"/proc/{pid}/fd").iterdir():
                try:
                    target = os.readlink(fd)
                except OSError:
                    continue
                if target.startswith("socket:[") and target[8:-1] in inodes:
                    n += 1
        except OSError:
            pass
        counts.append(n)
    return counts


def wait_for_quiet(max_wait_s: float, busy_below: float = 0.25) -> float:
    """Wait up to ``max_wait_s`` until the host is < ``busy_below`` busy over 2 s; the last
    busy fraction seen."""
    deadline = time.monotonic() + max_wait_s
    while True:
        b0, t0 = host_cpu_s()
        time.sleep(2.0)
        b1, t1 = host_cpu_s()
        busy = (b1 - b0) / max(t1 - t0, 1e-9)
        if busy < busy_below or time.monotonic() >= deadline:
            return busy


def self_cpu_s() -> float:
    """CPU seconds of this process (all its threads)."""
    return time.process_time()


@dataclass
class CpuSnapshot:
    """CPU counters at one instant."""

    server: dict[int, float]
    postgres: dict[int, float]
    client: float
    host_busy: float
    host_total: float
    others: dict[int, float]  # every other process: not this script's tree nor its backends


# --------------------------------------------------------------------------- databases


class Postgres:
    """A benchmark database on the PostgreSQL server of ``admin_url``, dropped by ``drop``."""

    def __init__(self, admin_url: str) -> None:
        from sqlalchemy import create_engine
        from sqlalchemy.engine import make_url

        self.name = f"rcb_bench_{secrets.token_hex(6)}"
        self.admin = create_engine(admin_url, isolation_level="AUTOCOMMIT", pool_pre_ping=True)
        self.url = make_url(admin_url).set(database=self.name).render_as_string(False)
        self.created = False

    def create(self) -> None:
        from sqlalchemy import text

        with self.admin.connect() as connection:
            connection.execute(text(f'CREATE DATABASE "{self.name}"'))
        self.created = True

    def backend_pids(self) -> list[int]:
        from sqlalchemy import text

        with self.admin.connect() as connection:
            rows = connection.execute(
                text("SELECT pid FROM pg_stat_activity WHERE datname = :d"), {"d": self.name}
            )
            return [int(r[0]) for r in rows]

    def sessions(self) -> int:
        """Sessions (connections) opened on the benchmark database so far (PostgreSQL >= 14;
        the statistics lag by up to a second)."""
        from sqlalchemy import text

        with self.admin.connect() as connection:
            value = connection.execute(
                text("SELECT sessions FROM pg_stat_database WHERE datname = :d"), {"d": self.name}
            ).scalar()
        return int(value or 0)

    def drop(self) -> None:
        from sqlalchemy import text

        if self.created:
            with self.admin.connect() as connection:
                connection.execute(text(f'DROP DATABASE IF EXISTS "{self.name}" WITH (FORCE)'))
            self.created = False
        self.admin.dispose()


# --------------------------------------------------------------------------- the server


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def create_key(url: str, role: str) -> str:
    """A new API key of ``role`` from ``rcb keys create`` (migrates the database first)."""
    proc = subprocess.run(
        [str(RCB), "keys", "create", "--role", role, "--label", "api_load", "--db", url, "--json"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
        check=False,
    )
    if proc.returncode != 0:
        raise RuntimeError(f"rcb keys create failed (exit {proc.returncode}): {proc.stderr}")
    return str(json.loads(proc.stdout)["key"])


class Server:
    """``rcb serve`` in its own process group on 127.0.0.1 and a free port."""

    def __init__(self, url: str, workers: int, log: Path, nodelay_fix: bool = False) -> None:
        self.url, self.workers, self.log = url, workers, log
        self.nodelay_fix = nodelay_fix
        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}{PREFIX}"
        self.process: subprocess.Popen[bytes] | None = None

    def start(self, timeout_s: float = 120.0) -> None:
        command = [str(RCB), "serve", "--db", self.url, "--port", str(self.port)]
        if self.nodelay_fix:  # the same command, run through this script's patched launcher
            command[:1] = [sys.executable, str(Path(__file__).resolve()), NODELAY_LAUNCHER]
        command += ["--workers", str(self.workers), "--no-access-log"]
        with self.log.open("ab") as log:
            self.process = subprocess.Popen(
                command, stdout=log, stderr=subprocess.STDOUT, start_new_session=True, cwd=ROOT
            )
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(f"rcb serve exited: {self.log_tail()}")
            try:
                if httpx.get(f"{self.base}/health", timeout=1.0).status_code == 200:
                    if len(self.worker_pids()) >= self.workers:
                        return
            except httpx.HTTPError:
                pass
            time.sleep(0.1)
        raise RuntimeError(f"rcb serve did not answer in {timeout_s} s: {self.log_tail()}")

    def worker_pids(self) -> list[int]:
        """The processes serving requests: the workers, or the server itself with one."""
        if self.process is None:
            return []
        if self.workers == 1:
            return [self.process.pid]
        kids = descendants(self.process.pid)
        # uvicorn's workers are multiprocessing "spawn" children running uvicorn; skip helpers
        # such as multiprocessing's resource tracker (they use no CPU under load anyway)
        return [pid for pid in kids if "resource_tracker" not in _cmdline(pid)]

    def log_tail(self, lines: int = 30) -> str:
        try:
            return "\n".join(self.log.read_text(errors="replace").splitlines()[-lines:])
        except OSError:
            return "(no log)"

    def stop(self) -> None:
        """SIGTERM the process group, SIGKILL if it hangs."""
        if self.process is None:
            return
        try:
            os.killpg(self.process.pid, signal.SIGTERM)
            self.process.wait(timeout=15)
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, signal.SIGKILL)
            self.process.wait(timeout=10)
        except ProcessLookupError:
            pass
        self.process = None


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


# --------------------------------------------------------------------------- plans and reports


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


# --------------------------------------------------------------------------- one configuration


@dataclass
class Result:
    """The figures of one configuration."""

    backend: str
    workers: int
    clients: int
    plans: int
    ops: int
    duration: float
    nodelay_fix: bool = False
    window_s: float = 0.0
    ok: int = 0
    errors: Counter[str] = field(default_factory=Counter)
    rps: float = 0.0
    p50: float = float("nan")
    p95: float = float("nan")
    p99: float = float("nan")
    mean: float = float("nan")
    maximum: float = float("nan")
    resolved: int = 0
    older: int = 0
    p50_resolved: float = float("nan")
    p50_hold: float = float("nan")
    warmup_reports: int = 0
    cpu: dict[str, float] = field(default_factory=dict)
    per_worker: list[float] = field(default_factory=list)
    connections: list[int] = field(default_factory=list)
    pg_sessions: int | None = None
    pg_backends: int = 0
    log_tail: str = ""


def percentiles(ms: list[float]) -> tuple[float, float, float]:
    if not ms:
        nan = float("nan")
        return nan, nan, nan
    if len(ms) == 1:
        return ms[0], ms[0], ms[0]
    q = statistics.quantiles(ms, n=100, method="inclusive")
    return q[49], q[94], q[98]


def snapshot(server: Server, pg: Postgres | None) -> CpuSnapshot:
    busy, total = host_cpu_s()
    server_cpu = {pid: process_cpu_s(pid) for pid in server.worker_pids()}
    pg_pids = pg.backend_pids() if pg else []
    pg_cpu = {pid: process_cpu_s(pid) for pid in pg_pids}
    mine = {os.getpid(), *descendants(os.getpid()), *pg_pids}
    others: dict[int, float] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and int(entry.name) not in mine:
            cpu = process_cpu_s(int(entry.name))
            if cpu is not None:
                others[int(entry.name)] = cpu
    return CpuSnapshot(
        {k: v for k, v in server_cpu.items() if v is not None},
        {k: v for k, v in pg_cpu.items() if v is not None},
        self_cpu_s(),
        busy,
        total,
        others,
    )


def cpu_used(before: CpuSnapshot, after: CpuSnapshot) -> tuple[dict[str, float], list[float]]:
    """CPU seconds between two snapshots, by consumer; and per server worker."""
    workers = [after.server[p] - before.server.get(p, 0.0) for p in sorted(after.server)]
    postgres = sum(after.postgres[p] - before.postgres.get(p, 0.0) for p in after.postgres)
    used = {
        "server": sum(workers),
        "postgres": postgres,
        "client": after.client - before.client,
        "others": sum(v - before.others.get(p, 0.0) for p, v in after.others.items()),
        "host": after.host_busy - before.host_busy,
        "capacity": after.host_total - before.host_total,
    }
    return used, workers


def run_configuration(
    backend: str, workers: int, args: argparse.Namespace, stop: threading.Event, tmp: Path
) -> Result:
    """Fresh database, server, plans; warm-up; the measured window; cleanup."""
    result = Result(
        backend, workers, args.clients, args.plans, args.ops, args.duration, args.nodelay_fix
    )
    token = secrets.token_hex(4)
    pg: Postgres | None = None
    server: Server | None = None
    https: list[MesConnection] = []
    try:
        if backend == "postgres":
            pg = Postgres(args.postgres_url)
            pg.create()
            url = pg.url
        else:
            url = f"sqlite:///{tmp / f'rcb-{token}.db'}"
        engineer, mes = create_key(url, "engineer"), create_key(url, "mes")
        server = Server(url, workers, tmp / f"serve-{token}.log", args.nodelay_fix)
        server.start()
        warm = create_plans(
            server.base, engineer, args.clients if args.warmup > 0 else 0, args.ops, "warm", 4
        )
        made = create_plans(server.base, engineer, args.plans, args.ops, "bench", 4)
        plans = [View.of(int(p["id"]), p) for p in made]
        clients = []
        for c in range(args.clients):
            http = MesConnection(server.base, mes)
            https.append(http)
            if args.plans >= args.clients:
                owned = [View(v.plan_id, v.version, v.predicted) for v in plans[c :: args.clients]]
            else:
                v = plans[c % args.plans]
                owned = [View(v.plan_id, v.version, v.predicted)]
            warmup = View.of(int(warm[c]["id"]), warm[c]) if warm else None
            clients.append(Client(c, http, warmup, owned))
        budget = Budget(args.max_requests)
        begin = perf()
        warmup_end = begin + args.warmup
        window_start = warmup_end + (0.2 if args.warmup > 0 else 0.0)
        window_end = window_start + args.duration
        threads = [
            threading.Thread(
                target=run_client,
                args=(c, token, warmup_end, window_start, window_end, stop, budget),
                name=f"client-{c.index}",
                daemon=True,
            )
            for c in clients
        ]
        for t in threads:
            t.start()
        while perf() < window_start and not stop.is_set():
            time.sleep(min(0.05, max(0.0, window_start - perf())))
        before = snapshot(server, pg)
        result.connections = connections_per_process(sorted(before.server), server.port)
        sessions_before = pg.sessions() if pg else 0
        # PostgreSQL backends come and go (the pool opens and closes overflow connections):
        # poll them during the window, so those that end inside it are counted too
        backends = {pid: (cpu, cpu) for pid, cpu in before.postgres.items()}  # (start, last)
        next_note = window_start + 10.0
        while any(t.is_alive() for t in threads):
            time.sleep(0.25)
            if pg is not None:
                for pid in pg.backend_pids():
                    cpu = process_cpu_s(pid)
                    if cpu is not None:
                        backends[pid] = (backends.get(pid, (0.0, 0.0))[0], cpu)
            if perf() >= next_note and perf() < window_end:
                done = sum(len(c.samples) for c in clients)
                print(f"    ... {perf() - window_start:4.0f} s: {done} reports", file=sys.stderr)
                next_note += 10.0
        after = snapshot(server, pg)
        for pid, cpu in after.postgres.items():
            backends[pid] = (backends.get(pid, (0.0, 0.0))[0], cpu)
        if pg:
            time.sleep(1.0)  # let the backends flush their statistics
            result.pg_sessions = pg.sessions() - sessions_before
        samples = [s for c in clients for s in c.samples]
        result.warmup_reports = sum(c.warmup_reports for c in clients)
        for c in clients:
            result.errors.update({f"warm-up {k}": v for k, v in c.warmup_errors.items()})
        ok = [s for s in samples if s.status == 201]
        result.errors.update(str(s.status) for s in samples if s.status != 201)
        result.ok = len(ok)
        last = max((s.end for s in samples), default=window_start)
        result.window_s = max(last - window_start, 1e-9)
        result.rps = len(ok) / result.window_s
        ms = [(s.end - s.start) * 1e3 for s in ok]
        result.p50, result.p95, result.p99 = percentiles(ms)
        result.mean = statistics.fmean(ms) if ms else float("nan")
        result.maximum = max(ms, default=float("nan"))
        result.resolved = sum(s.resolved for s in ok)
        result.older = sum(s.older_version for s in ok)
        res_ms = [(s.end - s.start) * 1e3 for s in ok if s.resolved]
        hold_ms = [(s.end - s.start) * 1e3 for s in ok if not s.resolved]
        result.p50_resolved = statistics.median(res_ms) if res_ms else float("nan")
        result.p50_hold = statistics.median(hold_ms) if hold_ms else float("nan")
        result.cpu, result.per_worker = cpu_used(before, after)
        result.cpu["postgres"] = sum(last - first for first, last in backends.values())
        result.pg_backends = len(backends)
        if any(not k.startswith("4") for k in result.errors):
            result.log_tail = server.log_tail()
        return result
    except KeyboardInterrupt:
        stop.set()
        raise
    finally:
        for http in https:
            http.close()
        if server is not None:
            server.stop()
        if pg is not None:
            pg.drop()


# --------------------------------------------------------------------------- printing


def machine_info() -> None:
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else "?"
    print("Machine")
    print(f"  python      {sys.version.split()[0]} ({platform.python_implementation()})")
    print(f"  platform    {platform.platform()}")
    print(f"  CPUs        {os.cpu_count()} logical, {usable} usable by this process")
    print(f"  code        {git_revision()}")


def git_revision() -> str:
    """The commit the service runs from, and whether the working tree differs from it."""
    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            cwd=ROOT,
        ).stdout.strip()
    except OSError:
        return "unknown (no git)"
    if not head:
        return "unknown (not a git checkout)"
    return f"commit {head}" + (" + uncommitted changes to tracked files" if dirty else "")


def describe(r: Result) -> str:
    return (
        f"{r.backend}, {r.workers} worker(s), {r.clients} clients, {r.plans} plan(s) of "
        f"{r.ops} operation(s), {r.duration:g} s" + (", listener patched" if r.nodelay_fix else "")
    )


def print_result(r: Result) -> None:
    errors = sum(r.errors.values())
    kinds = ", ".join(f"{k}: {v}" for k, v in sorted(r.errors.items())) or "none"
    print(
        f"  reports ok     {r.ok} in {r.window_s:.2f} s  (warm-up, not counted: {r.warmup_reports})"
    )
    print(f"  errors         {errors}  ({kinds})")
    print(f"  throughput     {r.rps:.1f} reports/s")
    print(
        f"  latency        p50 {r.p50:.1f} ms   p95 {r.p95:.1f} ms   p99 {r.p99:.1f} ms   "
        f"mean {r.mean:.1f} ms   max {r.maximum:.1f} ms"
    )
    share = 100.0 * r.resolved / r.ok if r.ok else float("nan")
    print(
        f"  re-solved      {r.resolved} reports ({share:.1f} %) moved a band and re-optimised; "
        f"p50 {r.p50_resolved:.1f} ms vs {r.p50_hold:.1f} ms for holds"
    )
    if r.ok:
        print(
            f"  in flight      throughput x mean latency = {r.rps * r.mean / 1e3:.1f} reports "
            f"(closed loop: about --clients; mean latency ~ clients / throughput)"
        )
    if r.plans < r.clients:
        print(f"  older version  {r.older} reports were made with a superseded setpoint version")
    cpu = r.cpu
    if cpu:
        per = ", ".join(
            f"{w:.1f} s/{n} conn."
            for w, n in zip(r.per_worker, r.connections or [0] * len(r.per_worker), strict=False)
        )
        per_report = 1e3 * (cpu["server"] + cpu["postgres"] + cpu["client"]) / r.ok if r.ok else 0.0
        rest = cpu["host"] - cpu["server"] - cpu["postgres"] - cpu["client"] - cpu["others"]
        print(
            f"  CPU [s]        server {cpu['server']:.1f} (per worker: {per}), postgres backends "
            f"{cpu['postgres']:.1f}, load generator {cpu['client']:.1f}"
        )
        print(
            f"                 other processes on the host {cpu['others']:.1f}, unattributed "
            f"(kernel, interrupts, short-lived processes) {max(rest, 0.0):.1f}; host busy "
            f"{cpu['host']:.1f} of {cpu['capacity']:.1f}"
        )
        print(
            f"  CPU per report {per_report:.1f} ms (server + postgres + load generator), i.e. "
            f"server {1e3 * cpu['server'] / max(r.ok, 1):.1f}, postgres "
            f"{1e3 * cpu['postgres'] / max(r.ok, 1):.1f}, client "
            f"{1e3 * cpu['client'] / max(r.ok, 1):.1f}"
        )
    if r.pg_sessions is not None:
        print(
            f"  connections    {r.pg_sessions} new PostgreSQL sessions opened during the window "
            f"(pg_stat_database.sessions), {r.pg_backends} backends seen (polled every 0.25 s; "
            f"the postgres CPU misses only backends that lived less than that)"
        )
    if r.backend == "postgres":
        p50_ok = "MET" if r.p50 <= TARGET_P50_MS else "NOT MET"
        rps_ok = "MET" if r.rps >= TARGET_RPS else "NOT MET"
        print(
            f"  targets        p50 <= {TARGET_P50_MS:g} ms: {p50_ok} ({r.p50:.1f} ms); "
            f">= {TARGET_RPS:g} reports/s: {rps_ok} ({r.rps:.1f})"
        )
    if r.log_tail:
        print("  server log (tail):")
        for line in r.log_tail.splitlines():
            print(f"    {line}")


HEADER = (
    "backend",
    "workers",
    "clients",
    "plans",
    "ops",
    "s",
    "reports ok",
    "errors",
    "reports/s",
    "p50 ms",
    "p95 ms",
    "p99 ms",
    "re-solved",
    "other load",
    "listener",
)


def row(r: Result) -> tuple[str, ...]:
    share = 100.0 * r.resolved / r.ok if r.ok else float("nan")
    return (
        r.backend,
        str(r.workers),
        str(r.clients),
        str(r.plans),
        str(r.ops),
        f"{r.window_s:.0f}",
        str(r.ok),
        str(sum(r.errors.values())),
        f"{r.rps:.0f}",
        f"{r.p50:.1f}",
        f"{r.p95:.1f}",
        f"{r.p99:.1f}",
        f"{share:.0f} %",
        f"{100 * other_load(r):.0f} %",
        "patched" if r.nodelay_fix else "stock",
    )


def other_load(r: Result) -> float:
    """Share of the host's CPU used by anything but the server, its database and the client."""
    cpu = r.cpu
    if not cpu or cpu["capacity"] <= 0:
        return float("nan")
    mine = cpu["server"] + cpu["postgres"] + cpu["client"]
    return max(0.0, cpu["host"] - mine) / cpu["capacity"]


def print_table(results: Sequence[Result], markdown: bool) -> None:
    rows = [HEADER, *(row(r) for r in results)]
    if markdown:
        print("| " + " | ".join(HEADER) + " |")
        print("|" + "|".join("---:" if i else "---" for i in range(len(HEADER))) + "|")
        for cells in rows[1:]:
            print("| " + " | ".join(cells) + " |")
        return
    widths = [max(len(cells[i]) for cells in rows) for i in range(len(HEADER))]
    for cells in rows:
        print("  " + "  ".join(c.rjust(w) for c, w in zip(cells, widths, strict=True)))


# --------------------------------------------------------------------------- main


@contextmanager
def interruptible() -> Iterator[threading.Event]:
    """Turn SIGTERM into KeyboardInterrupt; yield the event that stops the clients."""
    stop = threading.Event()

    def on_term(_signum: int, _frame: object) -> None:
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, on_term)
    try:
        yield stop
    except KeyboardInterrupt:
        stop.set()
        raise
    finally:
        stop.set()
        signal.signal(signal.SIGTERM, previous)


def positive_ints(text: str) -> list[int]:
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected integers separated by commas: {text!r}"
        ) from None
    if not values or any(v < 1 for v in values):
        raise argparse.ArgumentTypeError(f"expected positive integers: {text!r}")
    return values


#: First argument that makes this script the patched ``rcb`` launcher (``--nodelay-fix``).
NODELAY_LAUNCHER = "--launch-rcb-with-nodelay-listener"


def launch_rcb_with_nodelay_listener(rcb_args: list[str]) -> None:
    """Run ``rcb RCB_ARGS`` with uvicorn's ``Config.bind_socket`` returning an IPPROTO_TCP socket.

    uvicorn (0.54 here) binds the listener of ``--workers N > 1`` with
    ``socket.socket(family=...)``, i.e. ``proto`` 0; accepted connections inherit it and
    asyncio sets ``TCP_NODELAY`` only on sockets whose ``proto`` is ``IPPROTO_TCP``, so with
    several workers every response on a keep-alive connection is written with Nagle's
    algorithm on and waits for the client's delayed ACK (about 40 ms on Linux) between its
    header and body writes (Kludex/uvicorn issue #3149). ``--workers 1`` is not affected:
    asyncio builds that listener itself. This launcher re-wraps the same descriptor with
    ``proto=IPPROTO_TCP`` before the workers are spawned; the application is unchanged.
    """
    import uvicorn.config

    real_bind = uvicorn.config.Config.bind_socket

    def bind_socket(self: Any) -> socket.socket:
        sock = real_bind(self)
        if sock.family in (socket.AF_INET, socket.AF_INET6) and sock.proto == 0:
            tcp = socket.socket(sock.family, sock.type, socket.IPPROTO_TCP, fileno=sock.detach())
            tcp.set_inheritable(True)
            return tcp
        return sock

    uvicorn.config.Config.bind_socket = bind_socket  # type: ignore[method-assign]
    from api.cli.main import app

    sys.argv = ["rcb", *rcb_args]
    app()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--backend", choices=("sqlite", "postgres", "both"), default="both")
    parser.add_argument(
        "--workers", type=positive_ints, default=[2, 4], help="server worker counts (e.g. 2,4)"
    )
    parser.add_argument("--clients", type=int, default=16, help="concurrent clients")
    parser.add_argument(
        "--plans", type=int, default=None, help="plans the clients report to (default: --clients)"
    )
    parser.add_argument(
        "--ops", type=int, choices=(1, 6), default=6, help="operations per plan (demo part)"
    )
    parser.add_argument("--duration", type=float, default=30.0, help="measured window [s]")
    parser.add_argument("--warmup", type=float, default=3.0, help="warm-up [s] (0: none)")
    parser.add_argument(
        "--max-requests", type=int, default=200_000, help="cap on measured requests"
    )
    parser.add_argument(
        "--postgres-url", default=DEFAULT_POSTGRES, help="server URL to create databases on"
    )
    parser.add_argument(
        "--quiet-wait",
        type=float,
        default=0.0,
        help="wait up to this many seconds for the host to be idle (<25%% busy) before each run",
    )
    parser.add_argument(
        "--nodelay-fix",
        action="store_true",
        help="start rcb serve with uvicorn's listening socket created as IPPROTO_TCP (see above)",
    )
    parser.add_argument("--markdown", action="store_true", help="summary as a markdown table")
    args = parser.parse_args(argv)
    if args.clients < 1 or args.duration <= 0 or args.warmup < 0 or args.max_requests < 1:
        parser.error("--clients, --duration and --max-requests must be positive")
    args.plans = args.clients if args.plans is None else args.plans
    if args.plans < 1:
        parser.error("--plans must be positive")
    backends = ("sqlite", "postgres") if args.backend == "both" else (args.backend,)

    machine_info()
    print()
    print(
        f"Load: {args.clients} client threads (one keep-alive http.client connection each, closed "
        f"loop), {args.plans} plan(s) of {args.ops} operation(s) of {PLAN_FILE.name}; "
        f"{args.warmup:g} s warm-up on separate plans, then {args.duration:g} s measured "
        f"(at most {args.max_requests} reports)."
    )
    print(
        "Latency: client wall time per POST /plans/{id}/parts (request sent to answer read). "
        "The load generator runs on the same CPUs as the server and the database."
    )
    results: list[Result] = []
    started = perf()
    with tempfile.TemporaryDirectory(prefix="rcb_api_load_") as tmp, interruptible() as stop:
        for backend in backends:
            for workers in args.workers:
                print()
                result = Result(
                    backend,
                    workers,
                    args.clients,
                    args.plans,
                    args.ops,
                    args.duration,
                    args.nodelay_fix,
                )
                print(f"Configuration: {describe(result)}")
                if args.quiet_wait > 0:
                    busy = wait_for_quiet(args.quiet_wait)
                    print(f"  host before    {100 * busy:.0f} % busy over 2 s (other work)")
                if hasattr(os, "getloadavg"):
                    print(f"  load avg       {os.getloadavg()[0]:.2f} (1 min) before the run")
                try:
                    result = run_configuration(backend, workers, args, stop, Path(tmp))
                except (RuntimeError, OSError) as err:
                    print(f"  FAILED: {err}")
                    continue
                results.append(result)
                print_result(result)
                sys.stdout.flush()
    print()
    print(
        "Summary (re-solved: share of reports that moved a band and re-optimised the plan; "
        "other load: share of the host's CPU used by other work during the window)"
    )
    print_table(results, args.markdown)
    pg = [r for r in results if r.backend == "postgres"]
    if pg:
        print()
        print(
            f"Targets (PostgreSQL, from the issue): p50 <= {TARGET_P50_MS:g} ms and "
            f">= {TARGET_RPS:g} reports/s"
        )
        for r in pg:
            met = r.p50 <= TARGET_P50_MS and r.rps >= TARGET_RPS
            print(
                f"  {describe(r):<70} {'MET' if met else 'NOT MET'} "
                f"(p50 {r.p50:.1f} ms, {r.rps:.0f} reports/s)"
            )
    print()
    print(f"Total benchmark wall time {perf() - started:.0f} s")
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == NODELAY_LAUNCHER:
        sys.path.insert(0, str(ROOT))
        launch_rcb_with_nodelay_listener(sys.argv[2:])
    try:
        sys.exit(main())
    except KeyboardInterrupt:
        print("\ninterrupted: servers stopped, benchmark databases dropped", file=sys.stderr)
        sys.exit(130)
