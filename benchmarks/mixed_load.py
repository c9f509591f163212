"""Mixed load: do readers starve the MES? (issue 17 item 3; run on demand).

For each backend, on a fresh database and a real ``rcb serve --workers W`` (as
:mod:`benchmarks.api_load` starts it): one plan is created and seeded by the MES clients for
``--seed`` seconds (its history grows), then the MES clients report for ``--duration``
seconds alone, then for ``--duration`` seconds while ``--viewers`` threads read the plan's
history (``GET /plans/{id}/history``, viewer key) back to back. It prints the MES reports per
second of both windows and their ratio (target >= 50 %), and the history reads done. Bounded:
every window has a fixed length, and every request a 120 s timeout.

    python -m benchmarks.mixed_load --backend both --clients 1 --viewers 4 --duration 15
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import secrets
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx

from benchmarks.api_load.clients import MesConnection, View, create_plans
from benchmarks.api_load.config import DEFAULT_POSTGRES
from benchmarks.api_load.server import Postgres, Server, create_key

perf = time.perf_counter


@dataclass
class Window:
    """What one window measured."""

    seconds: float
    reports: int
    errors: int
    reads: int
    read_errors: int

    @property
    def reports_per_s(self) -> float:
        """MES reports answered 201 per second."""
        return self.reports / self.seconds


def _mes(base: str, key: str, view: View, token: str, end: float, out: list[int]) -> View:
    http = MesConnection(base, key)
    n = ok = bad = 0
    try:
        while perf() < end:
            n += 1
            serial = f"{token}-{n}"
            try:
                status, answer = http.post(
                    f"/plans/{view.plan_id}/parts", view.report(serial), serial
                )
            except OSError:
                bad += 1
                continue
            if status == 201:
                ok += 1
                view = View.of(view.plan_id, json.loads(answer))
            else:
                bad += 1
    finally:
        http.close()
    out[0] += ok
    out[1] += bad
    return view


def _viewer(base: str, key: str, plan_id: int, end: float, out: Any) -> None:
    """Read the plan's history back to back until ``end``; ``out``: (good, bad) counts.

    Runs in its own process, as a viewer's browser or script runs on its own machine: the
    MES client's thread must not share an interpreter lock with four readers.
    """
    good = bad = 0
    with httpx.Client(headers={"Authorization": f"Bearer {key}"}, timeout=120.0) as c:
        while perf() < end:
            try:
                ok = c.get(f"{base}/plans/{plan_id}/history").status_code == 200
            except httpx.HTTPError:
                ok = False
            good, bad = good + ok, bad + (not ok)
    out.put((good, bad))


def window(
    base: str, keys: dict[str, str], views: list[View], seconds: float, viewers: int
) -> Window:
    """MES clients (one per view, each on its own plan) for ``seconds``, with ``viewers``."""
    end = perf() + seconds
    counts, lock = [0, 0], threading.Lock()
    token = secrets.token_hex(4)
    spawn = multiprocessing.get_context("spawn")
    queue = spawn.Queue()
    readers = [
        spawn.Process(target=_viewer, args=(base, keys["viewer"], views[0].plan_id, end, queue))
        for _ in range(viewers)
    ]
    results: list[View | None] = [None] * len(views)

    def mes(i: int) -> None:
        per = [0, 0]
        results[i] = _mes(base, keys["mes"], views[i], f"{token}-{i}", end, per)
        with lock:
            counts[0] += per[0]
            counts[1] += per[1]

    threads = [threading.Thread(target=mes, args=(i,)) for i in range(len(views))]
    start = perf()
    for p in readers:
        p.start()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    reads = [0, 0]
    for _ in readers:
        good, bad = queue.get(timeout=180)
        reads = [reads[0] + good, reads[1] + bad]
    for p in readers:
        p.join(timeout=30)
    elapsed = max(seconds, perf() - start)
    for i, v in enumerate(results):
        if v is not None:
            views[i] = v
    return Window(elapsed, counts[0], counts[1], reads[0], reads[1])


def run_backend(url: str, args: argparse.Namespace, log: Path) -> tuple[Window, Window]:
    """Seed, then the window without viewers and the one with them."""
    keys = {role: create_key(url, role) for role in ("mes", "engineer", "viewer")}
    server = Server(url, args.workers, log)
    server.start()
    try:
        answers = create_plans(server.base, keys["engineer"], args.clients, 6, "mixed", 1)
        views = [View.of(int(a["id"]), a) for a in answers]
        window(server.base, keys, views, args.seed, 0)
        alone = window(server.base, keys, views, args.duration, 0)
        mixed = window(server.base, keys, views, args.duration, args.viewers)
        return alone, mixed
    finally:
        server.stop()


def main(argv: list[str] | None = None) -> None:
    """Run the mixed load on the chosen backends and print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backend", choices=("sqlite", "postgres", "both"), default="both")
    parser.add_argument("--postgres", default=DEFAULT_POSTGRES)
    parser.add_argument("--clients", type=int, default=1, choices=range(1, 17))
    parser.add_argument("--viewers", type=int, default=4, choices=range(0, 17))
    parser.add_argument("--workers", type=int, default=2, choices=range(1, 9))
    parser.add_argument("--duration", type=float, default=15.0, help="seconds per window (<= 120)")
    parser.add_argument("--seed", type=float, default=10.0, help="seconds of seeding (<= 120)")
    args = parser.parse_args(argv)
    args.duration, args.seed = min(args.duration, 120.0), min(args.seed, 120.0)
    backends = ["sqlite", "postgres"] if args.backend == "both" else [args.backend]
    print(
        f"{args.clients} MES client(s), {args.viewers} viewers, {args.workers} workers, "
        f"{args.seed:g} s seed, {args.duration:g} s windows"
    )
    for backend in backends:
        with tempfile.TemporaryDirectory() as tmp:
            pg = None
            if backend == "sqlite":
                url = f"sqlite:///{Path(tmp) / 'mixed.db'}"
            else:
                pg = Postgres(args.postgres)
                pg.create()
                url = pg.url
            try:
                alone, mixed = run_backend(url, args, Path(tmp) / "serve.log")
            finally:
                if pg is not None:
                    pg.drop()
        print(
            f"{backend:8s} MES alone {alone.reports} reports ({alone.reports_per_s:.1f}/s), "
            f"with viewers {mixed.reports} ({mixed.reports_per_s:.1f}/s): "
            f"{100 * mixed.reports_per_s / max(alone.reports_per_s, 1e-9):.0f} %; "
            f"history reads {mixed.reads} (errors: MES {alone.errors + mixed.errors}, "
            f"reads {mixed.read_errors})",
            flush=True,
        )


if __name__ == "__main__":
    main()
