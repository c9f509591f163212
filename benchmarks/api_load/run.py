"""One configuration (backend x workers): database, server, plans, warm-up, the window."""

from __future__ import annotations

import argparse
import os
import secrets
import statistics
import sys
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from benchmarks.api_load.clients import (
    Budget,
    Client,
    MesConnection,
    View,
    create_plans,
    run_client,
)
from benchmarks.api_load.config import perf
from benchmarks.api_load.cpu import (
    CpuSnapshot,
    connections_per_process,
    descendants,
    host_cpu_s,
    process_cpu_s,
    self_cpu_s,
)
from benchmarks.api_load.server import Postgres, Server, create_key


@dataclass
class Result:
    """The figures of one configuration."""

    backend: str
    workers: int
    clients: int
    plans: int
    ops: int
    duration: float
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
    result = Result(backend, workers, args.clients, args.plans, args.ops, args.duration)
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
        server = Server(url, workers, tmp / f"serve-{token}.log")
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
