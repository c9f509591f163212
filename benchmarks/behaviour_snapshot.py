"""Behaviour unchanged? ``rcb``'s deterministic outputs, the OpenAPI document and a closed-loop
digest of this checkout against a git revision (issue 31: a refactor changes no byte).

Every command of :data:`COMMANDS` runs in a fresh folder holding a copy of ``examples/`` and
``tests/data/``, once with this checkout and once with the code of ``--against`` (exported with
``git archive`` to a temporary folder and put first on ``PYTHONPATH``), both with the
interpreter running this script, ``COLUMNS=80`` and no colours. Their exit codes, standard
outputs and standard errors are compared byte for byte, after :data:`VOLATILE` (wall times)
is blanked. Beside them: the OpenAPI document of ``create_app`` (no server) and the digest of
``benchmarks/closed_loop.py`` on a few scenarios of every strategy (the same digest is the same
per-scenario result, bit for bit).

Run on demand, not a test; exit 0 when everything is the same, 1 when something differs (the
first differing lines of each are printed)::

    .venv/bin/python benchmarks/behaviour_snapshot.py --against main
    .venv/bin/python benchmarks/behaviour_snapshot.py --against HEAD~3 --only optimize
"""

from __future__ import annotations

import argparse
import difflib
import io
import os
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted(p.name for p in (ROOT / "examples").glob("*.toml"))
#: (name, arguments of ``rcb``): deterministic commands only (no database clock, no timing).
COMMANDS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("help", ("--help",)),
    ("examples", ("examples",)),
    ("demo", ("demo", "--parts", "5")),
    *((f"optimize {name}", ("optimize", f"examples/{name}")) for name in EXAMPLES),
    *((f"optimize --json {name}", ("optimize", f"examples/{name}", "--json")) for name in EXAMPLES),
    (
        "certify",
        ("certify", "examples/ivester_demo_part.toml", "--scenarios", "4", "--parts", "5"),
    ),
    (
        "certify faults",
        (
            "certify",
            "examples/ivester_demo_part.toml",
            "--scenarios",
            "4",
            "--parts",
            "16",
            "--fault",
            "dropout:0.1",
            "--fault",
            "step:8:1.12",
            "--json",
            "--jobs",
            "1",
        ),
    ),  # fmt: skip
    (
        "fit",
        (
            "fit",
            "data/nasa_milling_wear_labels.csv",
            "--process",
            "milling",
            "--life-to-wear",
            "0.3",
            "--response",
            "time",
            "--var",
            "axial_depth_mm=DOC",
            "--var",
            "feed_per_tooth_mm=feed/6",
            "--where",
            "material=1",
        ),
    ),  # fmt: skip
    (
        "predict",
        (
            "predict",
            "--tool",
            "CNMG432RN",
            "--depth-mm",
            "3",
            "--feed-mm-rev",
            "0.3",
            "--speed-m-min",
            "200",
        ),
    ),  # fmt: skip
    ("bad input", ("optimize", "examples/missing.toml")),
)
#: Wall times and rates in outputs: blanked before comparing.
VOLATILE = re.compile(r"\d+(\.\d+)? ?(s|ms|parts/s)\b|\"seconds\": [0-9.e+-]+")
OPENAPI = (
    "import json; from api.rest.app import create_app; "
    "print(json.dumps(create_app('sqlite:///unused.db').openapi(), indent=1, sort_keys=True))"
)


@dataclass(frozen=True)
class Outcome:
    """What one command printed, with what is volatile blanked."""

    code: int
    out: str
    err: str


#: The prefix of a script of the checkout being run (the revision's own script runs its code).
SCRIPT = "@code/"


def _run(source: Path, argv: list[str], work: Path) -> Outcome:
    """``argv`` with ``source``'s code; a script named by :data:`SCRIPT` is ``source``'s own."""
    argv = [str(source / a[len(SCRIPT) :]) if a.startswith(SCRIPT) else a for a in argv]
    env = dict(
        os.environ, PYTHONPATH=str(source), COLUMNS="80", NO_COLOR="1", TERM="dumb", CI="true"
    )
    done = subprocess.run(
        [sys.executable, *argv], cwd=work, env=env, capture_output=True, text=True, check=False
    )
    return Outcome(done.returncode, VOLATILE.sub("T", done.stdout), VOLATILE.sub("T", done.stderr))


def _folder(base: Path, name: str) -> Path:
    work = base / re.sub(r"\W+", "_", name)
    shutil.copytree(ROOT / "examples", work / "examples")
    shutil.copytree(ROOT / "tests" / "data", work / "data")
    return work


def _programs(only: str | None) -> list[tuple[str, list[str]]]:
    rcb = ["-c", "from api.cli.main import app; app()"]
    found = [(name, [*rcb, *args]) for name, args in COMMANDS]
    found.append(("openapi", ["-c", OPENAPI]))
    loop = SCRIPT + "benchmarks/closed_loop.py"
    found.append(("closed loop digest", [loop, "--scenarios", "6", "--parts", "8", "--jobs", "1"]))
    return [(n, a) for n, a in found if only is None or only in n]


def _digest(text: str) -> str:
    match = re.search(r"Digest of all per-scenario results: (\w+)", text)
    return match.group(1) if match else text


def _export(rev: str, into: Path) -> Path:
    archive = subprocess.run(["git", "archive", rev], cwd=ROOT, capture_output=True, check=True)
    with tarfile.open(fileobj=io.BytesIO(archive.stdout)) as tar:
        tar.extractall(into, filter="data")
    return into


def _differences(name: str, now: Outcome, before: Outcome) -> list[str]:
    if name == "closed loop digest":
        now = Outcome(now.code, _digest(now.out), "")
        before = Outcome(before.code, _digest(before.out), "")
    lines = [] if now.code == before.code else [f"  exit code {before.code} -> {now.code}"]
    for part, a, b in (("stdout", before.out, now.out), ("stderr", before.err, now.err)):
        diff = list(
            difflib.unified_diff(a.splitlines(), b.splitlines(), "before", "now", n=0, lineterm="")
        )
        lines += [f"  {part}: {line}" for line in diff[2:14]]
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--against", required=True, help="git revision to compare with")
    parser.add_argument("--only", help="run only the checks whose name contains this")
    args = parser.parse_args(argv)
    programs = _programs(args.only)
    if not programs:
        print(f"--only {args.only!r}: no check has it in its name", file=sys.stderr)
        return 2
    differ = 0
    with tempfile.TemporaryDirectory(prefix="rcb-snapshot-") as tmp:
        base = Path(tmp)
        old = _export(args.against, base / "before")
        for name, program in programs:
            now = _run(ROOT, program, _folder(base / "now", name))
            before = _run(old, program, _folder(base / "old", name))
            lines = _differences(name, now, before)
            differ += bool(lines)
            print(f"{'DIFFERS' if lines else 'same   '}  {name}")
            for line in lines:
                print(line)
    print(f"{len(programs) - differ} of {len(programs)} the same as {args.against}")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
