"""Scale-out benchmark: N ``rcb serve`` instances through PgBouncer on one PostgreSQL (issue 33).

Per configuration ``INSTANCESxWORKERS`` (``--configs 1x4,2x2,4x4``), on a fresh PostgreSQL
database (dropped at the end):

1. a PgBouncer (Debian's ``pgbouncer``; ``-u nobody`` when run as root) in transaction
   pooling with ``--server-pool`` server connections (``default_pool_size``) in front of it;
2. the instances, each ``rcb serve --workers W`` on a free port of 127.0.0.1, with
   ``?pgbouncer=transaction`` on their URL (``db/urls.py``);
3. ``--clients`` closed-loop MES clients (``benchmarks/api_load``'s: a kept-alive connection,
   the ``mes`` key, reports at the predictions of the setpoints last received), each with a
   fresh six-operation demonstration plan and an instance (client ``c`` on instance
   ``c mod N``), for ``--seconds`` (a plan learns, re-solving, through the whole window);
4. every 0.2 s, the connections PostgreSQL holds for the database (``pg_stat_activity``).

It prints one row per configuration: reports/s, p50 and p99 latency (the client's wall time
of a report), errors, the peak of server connections, and whether the plant rate (a 10 000
machine plant reports 83 parts/s) held with p99 under 250 ms. Run on demand (not a test)::

    .venv/bin/python benchmarks/scale_out.py --configs 1x4,2x2,4x4 --clients 8 --seconds 20

A closed loop holds ``--clients`` reports in flight: by Little's law the mean latency is
clients / throughput, so on a small host more clients raise the latency, not the rate.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from sqlalchemy import create_engine, text
from sqlalchemy.engine import make_url

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run as a script
from benchmarks.api_load.clients import MesConnection, View, create_plans  # noqa: E402
from benchmarks.api_load.server import Postgres, Server, create_key, free_port  # noqa: E402

RCB = Path(sys.executable).with_name("rcb")
PLANT_RATE = 83.0
P99_TARGET_MS = 250.0
#: Longest run of one configuration's window [s] and most clients (loops are bounded).
MAX_SECONDS, MAX_CLIENTS = 600.0, 256


@dataclass
class Run:
    """What one configuration measured."""

    instances: int
    workers: int
    latencies_s: list[float] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    wall_s: float = 0.0
    peak: int = 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--configs", default="1x4,2x2,4x4", help="INSTANCESxWORKERS, ...")
    parser.add_argument("--clients", type=int, default=8)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--server-pool", type=int, default=20, help="PgBouncer's pool")
    parser.add_argument(
        "--postgres-url", default="postgresql+psycopg://postgres@127.0.0.1:5432/test"
    )
    args = parser.parse_args(argv)
    pgbouncer = shutil.which("pgbouncer") or "/usr/sbin/pgbouncer"
    if not Path(pgbouncer).exists():
        parser.error("no pgbouncer: apt-get install pgbouncer")
    if not (1 <= args.clients <= MAX_CLIENTS and 1 <= args.seconds <= MAX_SECONDS):
        parser.error(f"--clients 1..{MAX_CLIENTS}, --seconds 1..{MAX_SECONDS:g}")
    try:
        configs = [tuple(int(n) for n in c.split("x")) for c in args.configs.split(",")]
    except ValueError:
        parser.error(f"--configs {args.configs!r}: INSTANCESxWORKERS, comma-separated")
    print(f"{args.clients} clients, {args.seconds:g} s, PgBouncer pool {args.server_pool}")
    print("| instances x workers | reports/s | p50 ms | p99 ms | errors | peak server conns |")
    print("| --- | --- | --- | --- | --- | --- |")
    for instances, workers in configs:
        run = measure(args, pgbouncer, instances, workers)
        quantiles = statistics.quantiles(run.latencies_s, n=100, method="inclusive")
        rate = len(run.latencies_s) / run.wall_s
        held = rate >= PLANT_RATE and quantiles[98] * 1e3 <= P99_TARGET_MS
        print(
            f"| {instances} x {workers} | {rate:.1f} | {quantiles[49] * 1e3:.0f} | "
            f"{quantiles[98] * 1e3:.0f} | {len(run.errors)} | {run.peak} |"
            f"{' plant rate with p99 <= 250 ms' if held else ''}",
            flush=True,
        )
    return 0


def measure(args: argparse.Namespace, pgbouncer: str, instances: int, workers: int) -> Run:
    """One configuration on a fresh database, everything it started stopped at the end."""
    database = Postgres(args.postgres_url)
    database.create()
    folder = Path(tempfile.mkdtemp(prefix="scale-out-"))
    folder.chmod(0o755)  # read by the unprivileged user PgBouncer runs as under root
    pgbouncer_process: list[subprocess.Popen[bytes]] = []
    servers: list[Server] = []
    try:
        url = _pgbouncer(database.url, folder, args.server_pool, pgbouncer, pgbouncer_process)
        subprocess.run([str(RCB), "db", "upgrade", "--db", url], check=True, capture_output=True)
        keys = {r: create_key(database.url, r) for r in ("engineer", "mes")}
        for i in range(instances):
            servers.append(Server(url, workers, folder / f"serve{i}.log"))
            servers[-1].start()
        bases = [server.base for server in servers]
        created = create_plans(bases[0], keys["engineer"], args.clients, 6, "scale", threads=4)
        views = [View.of(int(answer["id"]), answer) for answer in created]
        return _load(Run(instances, workers), database.url, bases, keys["mes"], views, args)
    finally:
        for server in servers:
            server.stop()
        for process in pgbouncer_process:
            os.killpg(process.pid, signal.SIGTERM)
            process.wait(60)
        shutil.rmtree(folder, ignore_errors=True)
        database.drop()


def _pgbouncer(
    direct: str, folder: Path, pool: int, binary: str, processes: list[subprocess.Popen[bytes]]
) -> str:
    target = make_url(direct)
    port = free_port()
    (folder / "pgbouncer.ini").write_text(
        f"[databases]\nrcb = host={target.host} port={target.port} "
        f"dbname={target.database} user={target.username}\n[pgbouncer]\n"
        f"listen_addr = 127.0.0.1\nlisten_port = {port}\nunix_socket_dir =\nauth_type = any\n"
        f"pool_mode = transaction\ndefault_pool_size = {pool}\nmax_client_conn = 4000\n"
        "ignore_startup_parameters = extra_float_digits,options\n"
    )
    user = ["-u", "nobody"] if os.geteuid() == 0 else []
    command = [binary, *user, str(folder / "pgbouncer.ini")]
    processes.append(subprocess.Popen(command, stderr=subprocess.DEVNULL, start_new_session=True))
    time.sleep(1.0)
    return f"postgresql+psycopg://{target.username}@127.0.0.1:{port}/rcb?pgbouncer=transaction"


def _load(
    run: Run, direct: str, bases: list[str], key: str, views: list[View], args: argparse.Namespace
) -> Run:
    stop = threading.Event()
    lock = threading.Lock()

    def sample() -> None:
        engine = create_engine(direct)
        query = text(
            "SELECT count(*) FROM pg_stat_activity WHERE datname = current_database() "
            "AND pid <> pg_backend_pid()"
        )
        try:
            while not stop.is_set():
                with engine.connect() as connection:
                    run.peak = max(run.peak, int(connection.execute(query).scalar() or 0))
                stop.wait(0.2)
        finally:
            engine.dispose()

    def client(i: int) -> None:
        connection, view = MesConnection(bases[i % len(bases)], key), views[i]
        end, n = time.perf_counter() + args.seconds, 0
        while time.perf_counter() < end:
            n += 1
            t0 = time.perf_counter()
            try:
                status, body = connection.post(
                    f"/plans/{view.plan_id}/parts", view.report(f"c{i}-{n}"), f"c{i}-{n}"
                )
            except OSError as err:
                status, body = type(err).__name__, b""
            with lock:
                run.latencies_s.append(time.perf_counter() - t0)
                if status != 201:
                    run.errors.append(str(status))
            if status == 201:
                view = View.of(view.plan_id, json.loads(body))
        connection.close()

    sampler = threading.Thread(target=sample)
    sampler.start()
    threads = [threading.Thread(target=client, args=(i,)) for i in range(len(views))]
    start = time.perf_counter()
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    run.wall_s = time.perf_counter() - start
    stop.set()
    sampler.join()
    return run


if __name__ == "__main__":
    sys.exit(main())
