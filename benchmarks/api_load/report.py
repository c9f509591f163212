"""What the benchmark prints: the machine, each configuration's figures, the summary."""

from __future__ import annotations

import os
import platform
import subprocess
import sys
from collections.abc import Sequence

from benchmarks.api_load.config import ROOT, TARGET_P50_MS, TARGET_RPS
from benchmarks.api_load.run import Result


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
        f"{r.ops} operation(s), {r.duration:g} s"
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
