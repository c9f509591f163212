"""History at scale (issue 17): one ``bayes`` plan grown to 100, 1000 and 5000 parts.

Every part goes through the real use case (``api.services.parts.report_part``: the RCB update,
the re-solve, a setpoint version per part) on a virtual lathe, into one SQLite file. At each
size the script prints: a report's latency warm (state cached) and on a cache miss (cache
cleared first), the first history page (``GET /plans/{id}/history``'s use case, 100 versions),
and ``rcb history`` (newest 50), ``rcb report``, ``rcb parts --last 50 --json`` and ``rcb export``
(csv, parquet) as separate processes, each with its wall time and peak memory (max RSS), and the
report's size. ``--reference CHECKOUT`` also runs ``rcb export`` from another checkout of the
project (an earlier commit's work tree, put first on ``PYTHONPATH``) on the same database, so a
change is measured against the code before it in one run. Run::

    .venv/bin/python benchmarks/history_scale.py --sizes 100 1000 5000 [--reference ../before]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import sysconfig
import tempfile
import time
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan
from api.services.read import history as read_history
from db.engine import make_engine, upgrade
from db.state_cache import CACHE
from supervisor.inputs.plan import plan_from_mapping
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start, update
from supervisor.virtual.sampling import sample_machine
from supervisor.virtual.simulate import run_part

ROOT = Path(__file__).resolve().parent.parent
BODY = tomllib.loads((ROOT / "examples" / "ivester_demo_part.toml").read_text(encoding="utf-8"))
RCB = str(Path(sys.executable).with_name("rcb"))


class Lathe:
    """Part reports as the MES sends them, made on a virtual lathe at the setpoints in force."""

    def __init__(self, settings: RcbSettings, seed: int = 3) -> None:
        plan = plan_from_mapping(BODY)
        self.machine, self.rng = sample_machine(plan, seed), np.random.default_rng(seed)
        self.state, self.count = start(plan, settings), 0

    def next(self) -> dict[str, Any]:
        """The next part's report (the offline RCB state follows, as the server's does)."""
        setpoints = {op.name: op.setpoint for op in self.state.setpoints.operations}
        outcome = run_part(self.machine, setpoints, self.rng)
        self.count += 1
        body = outcome.report(f"SN-{self.count:05d}", self.state.version)
        self.state, _ = update(self.state, parse_report(body))
        return body


def _ms(seconds: list[float]) -> float:
    return statistics.median(seconds) * 1000


def _process(args: list[str], checkout: Path | None = None) -> tuple[float, float, int]:
    """Wall time [s], peak memory [MB] and stdout size [bytes] of one ``rcb`` process.

    ``checkout``: run that work tree's code instead of this one's: Python without its site
    (``-S``, so the editable install's finder does not take this one's) and without the current
    directory (``-P``), the checkout then this environment's packages on ``PYTHONPATH``.
    """
    env, command = dict(os.environ), [RCB, *args]
    if checkout is not None:
        packages = sysconfig.get_paths()["purelib"]
        env["PYTHONPATH"] = os.pathsep.join([str(checkout.resolve()), packages])
        command = [sys.executable, "-S", "-P", "-c", "from api.cli.main import app; app()", *args]
    begin = time.perf_counter()
    child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env)
    out = child.stdout.read() if child.stdout else b""
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode != 0:
        raise SystemExit(f"rcb {' '.join(args)} exited {child.returncode}")
    return time.perf_counter() - begin, usage.ru_maxrss / 1024, len(out)


def measure(
    engine: Any, url: str, plan_id: int, lathe: Lathe, work: Path, reference: Path | None
) -> dict[str, float]:
    """The figures at the plan's present size (reports 10 more parts, 5 warm, 5 cold)."""
    warm, cold = [], []
    for timings, clear in ((warm, False), (cold, True)):
        for _ in range(5):
            body = lathe.next()
            if clear:
                CACHE.clear()
            begin = time.perf_counter()
            report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
            timings.append(time.perf_counter() - begin)
    page = []
    for _ in range(3):
        begin = time.perf_counter()
        read_history.plan_history(engine=engine, plan_id=plan_id)
        page.append(time.perf_counter() - begin)
    history = _process(["history", str(plan_id), "--db", url, "--json"])
    html = work / "report.html"
    report = _process(["report", str(plan_id), "--out", str(html), "--db", url])
    parts = _process(["parts", str(plan_id), "--last", "50", "--json", "--db", url])
    exports: dict[str, float] = {}
    for fmt in ("csv", "parquet"):
        for label, checkout in (("", None), ("reference ", reference)):
            if label and checkout is None:
                continue
            args = ["export", str(plan_id), "--format", fmt, "--out", str(work / "x"), "--db", url]
            seconds, mb, _ = _process(args, checkout)
            exports[f"{label}rcb export {fmt} s"], exports[f"{label}rcb export {fmt} MB"] = (
                seconds,
                mb,
            )
    return {
        "report warm ms": _ms(warm),
        "report cache miss ms": _ms(cold),
        "history page ms": _ms(page),
        "rcb history s": history[0],
        "rcb history MB": history[1],
        "rcb report s": report[0],
        "rcb report MB": report[1],
        "report page kB": html.stat().st_size / 1024,
        "rcb parts --last 50 s": parts[0],
        "rcb parts --last 50 MB": parts[1],
        **exports,
    }


def main() -> None:
    """Grow one plan to each size in turn and print the figures as a Markdown table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100, 1000, 5000])
    parser.add_argument("--reference", type=Path, help="a checkout whose rcb export to run too")
    args = parser.parse_args()
    settings = RcbSettings("bayes")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        url = f"sqlite:///{work / 'rcb.db'}"
        upgrade(url)
        engine = make_engine(url)
        plan_id = create_plan(engine=engine, body=BODY, settings=settings).body["id"]
        lathe = Lathe(settings)
        results: dict[int, dict[str, float]] = {}
        begin = time.perf_counter()
        for size in sorted(args.sizes):
            while lathe.count < size:
                report_part(engine=engine, plan_id=plan_id, report=parse_report(lathe.next()))
            seeded = time.perf_counter() - begin
            print(f"# {lathe.count} parts seeded through report_part ({seeded:.0f} s)", flush=True)
            results[size] = measure(engine, url, plan_id, lathe, work, args.reference)
            print(f"# {size}: {results[size]}", flush=True)
        engine.dispose()
    sizes = sorted(results)
    print("| figure | " + " | ".join(f"{n} parts" for n in sizes) + " |")
    print("|---|" + "---:|" * len(sizes))
    for figure in results[sizes[0]]:
        cells = " | ".join(f"{results[n][figure]:.3g}" for n in sizes)
        print(f"| {figure} | {cells} |")


if __name__ == "__main__":
    main()
