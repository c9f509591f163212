"""The command line: options, the configurations in turn, the summary and the targets."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import benchmarks.api_load as package
from benchmarks.api_load.config import DEFAULT_POSTGRES, PLAN_FILE, TARGET_P50_MS, TARGET_RPS, perf
from benchmarks.api_load.cpu import wait_for_quiet
from benchmarks.api_load.report import describe, machine_info, print_result, print_table
from benchmarks.api_load.run import Result, run_configuration


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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(package.__doc__ or "").split("\n\n")[0])
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
