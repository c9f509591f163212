"""Start-up of ``rcb``: wall time and peak memory of four commands, against a reference checkout.

Issue 18 item 8: ``rcb --help`` took about 2 s and 250 MB because every command module imported
cvxpy, SciPy, pandas, SQLAlchemy, matplotlib and uvicorn at the top; they are now imported where
a command runs (README, "Speed"). This script runs, each as a separate process, ``rcb --help``,
``rcb demo``, ``rcb optimize examples/ivester_demo_part.toml`` and ``rcb plans --db`` (an empty,
migrated SQLite database) ``--runs`` times, and prints per command the median wall time and the
median peak resident memory (``ru_maxrss`` of the child: what ``resource.getrusage
(RUSAGE_CHILDREN)`` reports, read per child with :func:`os.wait4`; a run over ``TIMEOUT_S`` is
killed). Beside them: a two-command Typer app's ``--help``, the floor no ``rcb --help`` can go
below on the host at that moment (the interpreter, typer and rich).

With ``--reference PATH`` (a checkout of other code, e.g. ``git worktree add /tmp/old c4c9685``
or ``git archive c4c9685 | tar -x -C /tmp/old``) the same commands run for the reference in the
same sitting, interleaved (each command runs for both sides in turn, this checkout first in
even rounds and the reference first in odd ones, so a drift of the host's speed weighs on both
alike), and the ratio this/reference is printed. Each side runs ``python -c "from api.cli.main
import app; app()"`` with its checkout first on ``PYTHONPATH``, by ``--reference-python``
(default: the reference's ``.venv/bin/python``, else this python: the same installed
libraries). ``--importtime`` also prints what ``python -X importtime -c "import api.cli.main"``
says the heavy libraries cost each side.

    .venv/bin/python benchmarks/cli_startup.py [--runs 5] [--reference ../old] [--importtime]
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: Most runs per command and side (a bound on the sitting: about 30 s per round before).
MAX_RUNS = 50
#: Longest one command may take [s].
TIMEOUT_S = 300.0
#: The libraries ``--importtime`` reports (SciPy's package alone is cheap: its stats module).
HEAVY = (
    "cvxpy",
    "scipy.stats",
    "pandas",
    "numpy",
    "sqlalchemy",
    "matplotlib",
    "fastapi",
    "uvicorn",
)
_RUN_RCB = "import sys; sys.argv[0] = 'rcb'; from api.cli.main import app; app()"
#: The floor: a two-command Typer app's ``--help`` (the interpreter, typer, rich), run as ``rcb``.
_RUN_FLOOR = (
    "import sys, typer; app = typer.Typer(add_completion=False); "
    "app.command('x')(lambda: None); app.command('y')(lambda: None); app()"
)
FLOOR = "(floor: 2-command Typer --help)"


@dataclass(frozen=True)
class Side:
    """A checkout and the python that runs it."""

    label: str
    root: Path
    python: Path

    def env(self) -> dict[str, str]:
        """The environment of a run: the checkout first on ``PYTHONPATH``, no colours."""
        path = os.pathsep.join([str(self.root), os.environ.get("PYTHONPATH", "")]).rstrip(
            os.pathsep
        )
        return dict(os.environ, PYTHONPATH=path, COLUMNS="80", NO_COLOR="1", TERM="dumb")


def commands(side: Side, work: Path) -> dict[str, list[str]]:
    """The measured commands of ``side``: name -> ``rcb`` arguments."""
    db = f"sqlite:///{work / (side.label + '.db')}"
    return {
        FLOOR: ["--help"],
        "rcb --help": ["--help"],
        "rcb demo": ["demo"],
        "rcb optimize": ["optimize", str(side.root / "examples" / "ivester_demo_part.toml")],
        "rcb plans (empty SQLite)": ["plans", "--db", db],
    }


def run(side: Side, args: list[str], work: Path, floor: bool = False) -> tuple[float, float]:
    """Wall time [s] and peak resident memory [MB] of one ``rcb`` process of ``side``.

    ``floor``: run the two-command Typer app instead (what no ``rcb --help`` can go below).
    """
    with tempfile.TemporaryFile() as output:
        begin = time.perf_counter()
        child = subprocess.Popen(
            [str(side.python), "-c", _RUN_FLOOR if floor else _RUN_RCB, *args],
            cwd=work,
            env=side.env(),
            stdout=output,
            stderr=subprocess.STDOUT,
        )
        timer = threading.Timer(TIMEOUT_S, child.kill)
        timer.start()
        _, status, usage = os.wait4(child.pid, 0)  # the child's own rusage: its peak memory
        wall = time.perf_counter() - begin
        timer.cancel()
        child.returncode = os.waitstatus_to_exitcode(status)
        if child.returncode != 0:
            output.seek(0)
            tail = output.read().decode("utf-8", "replace")[-1500:]
            raise SystemExit(
                f"{side.label}: rcb {' '.join(args)} exited {child.returncode}\n{tail}"
            )
    return wall, usage.ru_maxrss / 1024


def migrate(side: Side, work: Path) -> None:
    """Create the side's empty database (``rcb db upgrade``), not timed."""
    db = f"sqlite:///{work / (side.label + '.db')}"
    run(side, ["db", "upgrade", "--db", db], work)


def import_costs(side: Side, work: Path) -> dict[str, float]:
    """Cumulative import time [ms] of ``api.cli.main`` and of each :data:`HEAVY` library."""
    proc = subprocess.run(
        [str(side.python), "-X", "importtime", "-c", "import api.cli.main"],
        cwd=work,
        env=side.env(),
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
        check=True,
    )
    costs: dict[str, float] = {}
    for line in proc.stderr.splitlines():
        match = re.match(r"import time:\s+\d+ \|\s+(\d+) \|\s*(\S+)$", line)
        if match and match.group(2) in ("api.cli.main", *HEAVY):
            costs.setdefault(match.group(2), int(match.group(1)) / 1000)
    return costs


def _side(label: str, root: Path, python: Path | None) -> Side:
    if python is None:
        venv = root / ".venv" / "bin" / "python"
        python = venv if venv.exists() else Path(sys.executable)
    if not (root / "api" / "cli" / "main.py").is_file():
        raise SystemExit(f"{root}: not a checkout of rcb-supervisor (no api/cli/main.py)")
    return Side(label, root.resolve(), python)


def main(argv: list[str] | None = None) -> None:
    """Measure, interleaved, and print the medians (and ratios against the reference)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5, help=f"runs per command (1-{MAX_RUNS})")
    parser.add_argument("--reference", type=Path, help="a checkout of the code to compare with")
    parser.add_argument("--reference-python", type=Path, help="the python that runs it")
    parser.add_argument("--importtime", action="store_true", help="print the imports' costs")
    args = parser.parse_args(argv)
    if not 1 <= args.runs <= MAX_RUNS:
        parser.error(f"--runs must be between 1 and {MAX_RUNS}")
    sides = [_side("this", ROOT, Path(sys.executable))]
    if args.reference is not None:
        sides.append(_side("reference", args.reference, args.reference_python))
    figures: dict[tuple[str, str], list[tuple[float, float]]] = {}
    with tempfile.TemporaryDirectory(prefix="rcb-startup-") as tmp:
        work = Path(tmp)
        for side in sides:
            migrate(side, work)
        for n in range(args.runs):
            for name in commands(sides[0], work):
                for side in sides if n % 2 == 0 else sides[::-1]:
                    rcb_args = commands(side, work)[name]
                    figure = run(side, rcb_args, work, floor=name == FLOOR)
                    figures.setdefault((side.label, name), []).append(figure)
        costs = {s.label: import_costs(s, work) for s in sides} if args.importtime else {}
    _print(sides, figures, args.runs)
    if costs:
        _print_costs(costs)


def _print(
    sides: list[Side], figures: dict[tuple[str, str], list[tuple[float, float]]], n: int
) -> None:
    print(f"median of {n} run(s) per command; {sys.version.split()[0]}; {os.cpu_count()} CPUs")
    for side in sides:
        print(f"  {side.label}: {side.root} ({side.python})")
    head = f"{'command':<32}" + "".join(f"{s.label + ' s':>12}{s.label + ' MB':>13}" for s in sides)
    print(head + ("  ratio s / MB" if len(sides) > 1 else ""))
    names = list(dict.fromkeys(name for _, name in figures))
    for name in names:
        medians = []
        for side in sides:
            runs = figures[(side.label, name)]
            medians.append(
                (statistics.median(w for w, _ in runs), statistics.median(m for _, m in runs))
            )
        line = f"{name:<32}" + "".join(f"{w:>12.2f}{m:>13.0f}" for w, m in medians)
        if len(medians) > 1:
            (w0, m0), (w1, m1) = medians
            line += f"  {w0 / w1:.2f} / {m0 / m1:.2f}"
        print(line)


def _print_costs(costs: dict[str, dict[str, float]]) -> None:
    print("cumulative import time of `import api.cli.main` [ms] (-X importtime; - not imported)")
    for label, found in costs.items():
        parts = [f"{name} {found[name]:.0f}" if name in found else f"{name} -" for name in HEAVY]
        print(f"  {label}: total {found.get('api.cli.main', 0):.0f}; " + ", ".join(parts))


if __name__ == "__main__":
    main()
