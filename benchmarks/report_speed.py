"""Pages in under a second (issue 30): ``rcb report`` and ``/ui/plans/{id}`` of a 100-part plan.

The plan is the demonstration part (``examples/ivester_demo_part.toml``, the default RCB
strategy) with 100 parts from the virtual lathe, each through the real use case
(``api.services.parts.report_part``) into one SQLite file. Then, for this checkout and for
the code before issue 30 (``--before``, a git revision exported to a temporary directory and
run from there, same database):

- ``rcb report`` as a fresh process, ``--runs`` times (every run is cold: a new process);
- ``rcb serve`` started fresh ``--runs`` times: the first ``GET /ui/plans/{id}`` after the
  start (cold) and the median of ``--warm`` requests after it (warm), with a viewer's
  cookie, over HTTP on 127.0.0.1.

It prints each figure (median and max [s]), the page sizes and the ratio before / now, as a
Markdown table. Targets: <= 1 s warm, <= 3 s cold. Run::

    .venv/bin/python benchmarks/report_speed.py
    .venv/bin/python benchmarks/report_speed.py --before none   # this checkout only
"""

from __future__ import annotations

import argparse
import os
import signal
import socket
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import httpx
from history_scale import Lathe

from api.rest.schemas.parts import parse_report
from api.services.keys import create_key
from api.services.parts import report_part
from api.services.plans import create_plan
from db.engine import make_engine, upgrade
from supervisor.rcb.state import RcbSettings

ROOT = Path(__file__).resolve().parent.parent
BODY_FILE = ROOT / "examples" / "ivester_demo_part.toml"
#: main just before issue 30's report work: the plots drawn with matplotlib on every request.
BEFORE = "dfd4c07"
PARTS = 100
#: Run the project's CLI from a directory (the first on sys.path) rather than the install.
CLI = "import sys; sys.argv[0] = 'rcb'; from api.cli.main import app; app()"


def build(work: Path) -> tuple[str, int, str]:
    """The 100-part plan in ``work/rcb.db``: its URL, id, and a viewer's API key."""
    import tomllib

    body = tomllib.loads(BODY_FILE.read_text(encoding="utf-8"))
    url = f"sqlite:///{work / 'rcb.db'}"
    upgrade(url)
    engine = make_engine(url)
    settings = RcbSettings()
    plan_id = int(create_plan(engine=engine, body=body, settings=settings).body["id"])
    lathe = Lathe(settings)
    while lathe.count < PARTS:
        report_part(engine=engine, plan_id=plan_id, report=parse_report(lathe.next()))
    key = str(create_key(engine=engine, role="viewer", label="report_speed")["key"])
    engine.dispose()
    return url, plan_id, key


def export(revision: str, into: Path) -> Path:
    """The tree of ``revision`` (its Python packages) in ``into``."""
    archive = into / "before.tar"
    packages = ["api", "db", "models", "supervisor", "alembic"]
    with archive.open("wb") as out:
        subprocess.run(
            ["git", "-C", str(ROOT), "archive", revision, *packages], stdout=out, check=True
        )
    with tarfile.open(archive) as tar:
        tar.extractall(into / "tree", filter="data")
    return into / "tree"


def _command(tree: Path | None, *args: str) -> tuple[list[str], dict[str, str], Path]:
    environment = {**os.environ, "PYTHONPATH": str(tree or ROOT), "COLUMNS": "100"}
    return [sys.executable, "-c", CLI, *args], environment, tree or ROOT


def cli_runs(
    tree: Path | None, url: str, plan_id: int, out: Path, runs: int
) -> tuple[list[float], list[float]]:
    """Wall and CPU time [s] of ``rcb report`` as a fresh process, ``runs`` times."""
    command, environment, cwd = _command(
        tree, "report", str(plan_id), "--out", str(out), "--db", url
    )
    wall, cpu = [], []
    for _ in range(runs):
        begin = time.perf_counter()
        child = subprocess.Popen(
            command, env=environment, cwd=cwd,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip
        _, status, usage = os.wait4(child.pid, 0)
        wall.append(time.perf_counter() - begin)
        cpu.append(usage.ru_utime + usage.ru_stime)
        if os.waitstatus_to_exitcode(status) != 0:
            raise SystemExit(f"rcb report failed ({tree or ROOT})")
    return wall, cpu


def _cpu_s(pid: int) -> float:
    """CPU time [s] a process has used so far (user + system, /proc/PID/stat)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _serve(tree: Path | None, url: str) -> tuple[subprocess.Popen[bytes], str]:
    port = _free_port()
    args = ("serve", "--db", url, "--port", str(port), "--workers", "1", "--no-access-log")
    command, environment, cwd = _command(tree, *args)
    process = subprocess.Popen(
        command, env=environment, cwd=cwd, start_new_session=True,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    base = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            if httpx.get(f"{base}/api/v1/health", timeout=1.0).status_code == 200:
                return process, base
        except httpx.HTTPError:
            time.sleep(0.1)
    os.killpg(process.pid, signal.SIGKILL)
    raise SystemExit("rcb serve did not answer in 60 s")


def ui_runs(
    tree: Path | None, url: str, plan_id: int, key: str, runs: int, warm: int
) -> tuple[dict[str, list[float]], int]:
    """Wall and server CPU [s] of the first request per fresh server and of the warm ones,
    and the page's size."""
    times: dict[str, list[float]] = {"cold": [], "cold cpu": [], "warm": [], "warm cpu": []}
    size = 0
    for _ in range(runs):
        process, base = _serve(tree, url)
        try:
            with httpx.Client(base_url=f"{base}/ui", timeout=120.0) as client:
                if client.post("/login", data={"key": key}).status_code != 303:
                    raise SystemExit("the viewer's key was refused")
                for i in range(warm + 1):
                    begin, cpu = time.perf_counter(), _cpu_s(process.pid)
                    page = client.get(f"/plans/{plan_id}")
                    kind = "warm" if i else "cold"
                    times[kind].append(time.perf_counter() - begin)
                    times[f"{kind} cpu"].append(_cpu_s(process.pid) - cpu)
                    if page.status_code != 200:
                        raise SystemExit(f"/ui/plans/{plan_id}: {page.status_code}")
                    size = len(page.content)
        finally:
            os.killpg(process.pid, signal.SIGTERM)
            process.wait(timeout=30)
    return times, size


def measure(
    tree: Path | None, url: str, plan_id: int, key: str, args: argparse.Namespace
) -> dict[str, float]:
    """The figures of one code tree (None: this checkout)."""
    out = Path(tempfile.mkdtemp()) / "report.html"
    wall, cpu = cli_runs(tree, url, plan_id, out, args.runs)
    ui, size = ui_runs(tree, url, plan_id, key, args.runs, args.warm)
    figures = {
        "rcb report, fresh process: wall s": wall,
        "rcb report, fresh process: CPU s": cpu,
        "/ui page, first request after start (cold): wall s": ui["cold"],
        "/ui page, first request after start (cold): server CPU s": ui["cold cpu"],
        "/ui page, later requests (warm): wall s": ui["warm"],
        "/ui page, later requests (warm): server CPU s": ui["warm cpu"],
    }
    out_kb = out.stat().st_size / 1000
    return {
        **{f"{name} (median)": statistics.median(v) for name, v in figures.items()},
        **{f"{name} (max)": max(v) for name, v in figures.items()},
        "report page kB": out_kb,
        "/ui page kB": size / 1000,
    }


def main() -> None:
    """Build the plan, measure this checkout and the code before, print a Markdown table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default=BEFORE, help="git revision to compare; none: skip")
    parser.add_argument("--runs", type=int, default=3, help="fresh processes per figure")
    parser.add_argument("--warm", type=int, default=5, help="warm requests per server")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        begin = time.perf_counter()
        url, plan_id, key = build(work)
        print(f"# {PARTS} parts through report_part in {time.perf_counter() - begin:.0f} s; "
              f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}", flush=True)  # fmt: skip
        now = measure(None, url, plan_id, key, args)
        print(f"# now: {now}", flush=True)
        before = None
        if args.before != "none":
            before = measure(export(args.before, work), url, plan_id, key, args)
            print(f"# before ({args.before}): {before}", flush=True)
    head = "| figure | now |" + (f" before ({args.before}) | before / now |" if before else "")
    print(head)
    print("|---|---:|" + ("---:|---:|" if before else ""))
    for figure, value in now.items():
        cells = f"| {figure} | {value:.3g} |"
        if before:
            cells += f" {before[figure]:.3g} | {before[figure] / value:.1f} |"
        print(cells)


if __name__ == "__main__":
    main()
