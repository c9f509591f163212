"""Memory and time of ``rcb gcode`` on programs of 1 to 200 MB (issue 29, point 4/5).

Each program is a realistic lathe part (tool change, G96 spindle, a G71 roughing cycle with its
contour, an OD turn, a G70 finishing pass, a thread) repeated with new block numbers after a
``G21 G95 G96 G50 S3000`` header; ``rough-od`` is mapped to the first half of the repetitions
and ``finish-od`` to most of the rest, so every F and S word there is rewritten and every
thread lead and contour word warned about. Each program is handed to the ``rcb`` executable in
its own process with ``--json`` (stdout to a file), forked by a small launcher whose
``os.wait4`` gives the child's own peak resident memory (``ru_maxrss``) and its wall time.
The last case is one 10 MB line of ``F0.1`` words, which must be refused quickly, in little
memory, with a message of bounded length.

Printed per program: size [MB], wall time [s], peak RSS [MB], seconds per MB (constant when
time is linear in size), the JSON's size [MB] and the exit code. ``--rcb`` runs another
checkout's executable (e.g. the code before the streaming reader)::

    .venv/bin/python benchmarks/gcode_memory.py --sizes 1 10 50
    .venv/bin/python benchmarks/gcode_memory.py --sizes 1 10 --rcb /work/main/.venv/bin/rcb
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import tomllib
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RCB = Path(sys.executable).with_name("rcb")
#: The most ``rcb gcode`` may take on a 50 MB program [MB of peak RSS] (issue 29's acceptance).
TARGET_MB = 300.0
#: Header of every program: metric, feed per revolution, constant surface speed, the clamp.
_HEAD = "%\nO1001 (BENCHMARK PART, REPEATED)\nN1 G21 G40 G18 G95\nN2 G50 S3000\nN3 G28 U0. W0.\n"
#: One part (block numbers relative to its first, ``{n}`` + offset).
_PART = [
    "(ROUGH OD - T1 - CNMG432RN)",
    "N{0} T0101",
    "N{1} G96 S187 M03",
    "N{2} G00 X62. Z2. M08",
    "N{3} G71 U2. R0.5",
    "N{4} G71 P{5} Q{8} U0.4 W0.1 F0.25",
    "N{5} G00 X40. F0.12 S200",
    "N{6} G01 Z-20.",
    "N{7} X50. Z-40.",
    "N{8} X62.",
    "N{9} G01 Z-110. F0.25",
    "N{10} X64. F0.3 (RETRACT F0.3)",
    "N{11} G00 Z2.",
    "N{12} G70 P{5} Q{8} F0.1",
    "N{13} G00 X100. Z100. M09",
    "(THREAD - T5)",
    "N{14} T0505",
    "N{15} G97 S800 M03",
    "N{16} G00 X52. Z5.",
    "N{17} G32 Z-30. F2.0",
    "N{18} G00 X60.",
    "N{19} G96 S190 M03",
    "N{20} G01   Z-110.  F.1   (FINISH PASS)",
]
_STEP = 10  # between block numbers
_PER_PART = 21 * _STEP  # block numbers a part uses
#: Forks and runs ``argv[1:]`` with stdout to the file ``argv[1]``; writes ``ru_maxrss`` [kB] and
#: the wall time [s] of its child to its own stdout. Linux keeps in ``ru_maxrss`` the high-water
#: mark a process had when it called ``exec``: a child forked by this benchmark (which holds the
#: plan's database code) would report the benchmark's size. Forked from this small launcher
#: (``python -S``, a few MB), it reports its own.
_LAUNCHER = """
import os, sys, time
out = os.open(sys.argv[1], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
start = time.perf_counter()
pid = os.fork()
if pid == 0:
    os.dup2(out, 1)
    os.execv(sys.argv[2], sys.argv[2:])
_, status, usage = os.wait4(pid, 0)
sys.stdout.write(f"{usage.ru_maxrss} {time.perf_counter() - start}")
sys.exit(os.waitstatus_to_exitcode(status))
"""


@dataclass(frozen=True)
class Run:
    """One ``rcb gcode`` run: exit code, stderr, peak RSS [MB], wall time [s], stdout [bytes]."""

    exit_code: int
    stderr: str
    peak_mb: float
    seconds: float
    stdout_bytes: int


def write_program(path: Path, size_mb: float) -> tuple[Path, list[str]]:
    """A program of about ``size_mb`` MB of repeated parts, and its two ``--map`` ranges."""
    target = int(size_mb * 1e6)
    with path.open("w", encoding="ascii", newline="\n") as file:
        file.write(_HEAD)
        written, part, first = len(_HEAD), 0, 100
        while written < target or part == 0:
            n = first + part * _PER_PART
            text = "\n".join(_PART).format(*(n + k * _STEP for k in range(21))) + "\n"
            file.write(text)
            written += len(text)
            part += 1
        file.write(f"N{first + part * _PER_PART} M30\n%\n")
    half = max(part // 2, 1)
    rough = f"rough-od=N{first}:N{first + (half - 1) * _PER_PART + 20 * _STEP}"
    last = max(part - 1, half)
    finish = f"finish-od=N{first + half * _PER_PART}:N{first + last * _PER_PART + 20 * _STEP}"
    return path, [rough] if part < 2 else [rough, finish]


def write_long_line(path: Path, size_mb: float) -> Path:
    """One line of ``F0.1`` words of ``size_mb`` MB after a valid header."""
    words = int(size_mb * 1e6 / 5)
    path.write_bytes(_HEAD.encode() + b"N10" + b" F0.1" * words + b"\nN20 M30\n")
    return path


def store_plan(folder: Path) -> tuple[str, int]:
    """The demonstration plan in a new SQLite database: its URL and id."""
    from api.services.plans import create_plan
    from db.engine import make_engine, upgrade

    url = f"sqlite:///{folder / 'rcb.db'}"
    upgrade(url)
    engine = make_engine(url)
    body = tomllib.loads((ROOT / "examples" / "ivester_demo_part.toml").read_text("utf-8"))
    plan_id = int(create_plan(engine=engine, body=body).body["id"])
    engine.dispose()
    return url, plan_id


def run_gcode(rcb: Path, args: list[str], stdout: Path) -> Run:
    """``rcb gcode ARGS`` forked by :data:`_LAUNCHER`; stdout to ``stdout``."""
    launcher = [sys.executable, "-S", "-c", _LAUNCHER, str(stdout), str(rcb), "gcode", *args]
    done = subprocess.run(launcher, capture_output=True, check=False)
    peak_kb, seconds = (float(x) for x in done.stdout.decode().split())
    stderr = done.stderr.decode("utf-8", "replace")
    size = stdout.stat().st_size if stdout.exists() else 0
    return Run(done.returncode, stderr, peak_kb / 1024, seconds, size)  # Linux: kB


def main() -> int:
    """Print a row per program and the long line's refusal; exit 1 when one is over target."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=float, nargs="+", default=[1.0, 10.0, 50.0])
    parser.add_argument("--rcb", type=Path, default=RCB, help="the rcb executable to run")
    parser.add_argument("--long-line-mb", type=float, default=10.0)
    options = parser.parse_args()
    failed = False
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        url, plan_id = store_plan(folder)
        print(f"rcb: {options.rcb}")
        tiny, maps = write_program(folder / "TINY.nc", 0.0)
        args = [str(plan_id), "--program", str(tiny), "--out", str(folder / "o")]
        args += [x for m in maps for x in ("--map", m)] + ["--db", url, "--json"]
        start = run_gcode(options.rcb, args, folder / "o")
        print(
            f"start-up (one part, exit {start.exit_code}): {start.seconds:.2f} s, "
            f"{start.peak_mb:.0f} MB"
        )
        print(
            f"{'program':>10} {'s':>8} {'peak MB':>8} {'s/MB':>6} {'(s-start)/MB':>12} "
            f"{'JSON MB':>8} {'exit':>4}"
        )
        for size_mb in options.sizes:
            program, maps = write_program(folder / "IN.nc", size_mb)
            actual_mb = program.stat().st_size / 1e6
            args = [str(plan_id), "--program", str(program), "--out", str(folder / "OUT.nc")]
            args += [x for m in maps for x in ("--map", m)] + ["--db", url, "--json"]
            run = run_gcode(options.rcb, args, folder / "out.json")
            print(
                f"{actual_mb:>7.1f} MB {run.seconds:>8.1f} {run.peak_mb:>8.0f} "
                f"{run.seconds / actual_mb:>6.2f} "
                f"{(run.seconds - start.seconds) / actual_mb:>12.2f} "
                f"{run.stdout_bytes / 1e6:>8.2f} {run.exit_code:>4}"
            )
            if run.exit_code:
                print(f"  stderr: {run.stderr[:300]}")
            failed |= run.exit_code != 0 or (actual_mb <= 50.5 and run.peak_mb > TARGET_MB)
            program.unlink()
        line = write_long_line(folder / "LONG.nc", options.long_line_mb)
        args = [str(plan_id), "--program", str(line), "--out", str(folder / "OUT.nc")]
        args += ["--map", "rough-od=N10:N20", "--db", url]
        run = run_gcode(options.rcb, args, folder / "o")
        print(
            f"one line of F words, {line.stat().st_size / 1e6:.1f} MB: exit {run.exit_code}, "
            f"{run.seconds:.2f} s, peak {run.peak_mb:.0f} MB, "
            f"stderr {len(run.stderr)} characters:\n  {run.stderr[:400].rstrip()}"
        )
        failed |= run.exit_code != 2 or run.peak_mb > TARGET_MB
    print(f"target: up to 50 MB rewritten, the long line refused, each under {TARGET_MB:.0f} MB")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
