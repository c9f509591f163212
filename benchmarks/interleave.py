"""Run one benchmark in two checkouts, interleaved, and compare a figure it prints.

For a before/after comparison in one sitting (issue 16's acceptance: ``solve_speed`` and
``api_load`` within 5 %): the same command runs in the *before* and the *after* checkout, each
with its own ``.venv``, for ``--rounds`` rounds. The order alternates (before, after; then
after, before; ...), so a drift of the host's speed during the sitting weighs on both sides
alike. Each ``--figure`` regex is searched in a run's output (stdout and stderr); its first
group (a named group gives the figure its name) is the figure, from the first match. The
script prints every round's figures and, per figure, the median of each side and the ratio
after/before of the medians, and whether it lies within ``--tolerance``.

The command follows ``--`` and runs in the checkout's directory with that checkout's
``.venv/bin`` first on ``PATH``; the token ``{python}`` stands for the checkout's
``.venv/bin/python`` (without one, the command is run by that python). Example (from the
repository root)::

    .venv/bin/python benchmarks/interleave.py ../main . --rounds 5 \\
        --figure 'optimize_plan, re-solve\\s+median\\s+(?P<plan_ms>[\\d.]+) ms' \\
        -- benchmarks/solve_speed.py --no-subprocess
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Checkout:
    """A checkout of the project and the python of its virtual environment."""

    label: str
    directory: Path

    @property
    def python(self) -> Path:
        """The checkout's ``.venv/bin/python``."""
        return self.directory / ".venv" / "bin" / "python"


def command_for(checkout: Checkout, command: Sequence[str]) -> list[str]:
    """``command`` with ``{python}`` replaced by the checkout's python (prepended if absent)."""
    python = str(checkout.python)
    if not any("{python}" in token for token in command):
        return [python, *command]
    return [token.replace("{python}", python) for token in command]


def run_once(checkout: Checkout, command: Sequence[str], timeout_s: float | None) -> str:
    """The output (stdout, then stderr) of one run of ``command`` in ``checkout``."""
    bin_dir = str(checkout.python.parent)
    env = dict(os.environ, VIRTUAL_ENV=str(checkout.python.parent.parent))
    env["PATH"] = bin_dir + os.pathsep + env.get("PATH", "")
    proc = subprocess.run(
        command_for(checkout, command),
        cwd=checkout.directory,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout_s,
        check=False,
    )
    if proc.returncode != 0:
        raise RuntimeError(
            f"{checkout.label}: exit {proc.returncode}\n{proc.stdout[-2000:]}{proc.stderr[-2000:]}"
        )
    return proc.stdout + proc.stderr


def figures_of(output: str, patterns: Sequence[re.Pattern[str]]) -> list[float]:
    """The figure of each pattern in ``output``: its first group, from the first match."""
    values = []
    for pattern in patterns:
        match = pattern.search(output)
        if match is None:
            raise RuntimeError(f"no match for {pattern.pattern!r} in the output:\n{output[-2000:]}")
        values.append(float(match.group(1)))
    return values


def name_of(pattern: re.Pattern[str], index: int) -> str:
    """A figure's name: the regex's named group, else its position."""
    names = sorted(pattern.groupindex, key=pattern.groupindex.__getitem__)
    return names[0] if names and pattern.groupindex[names[0]] == 1 else f"figure {index + 1}"


def main(argv: Sequence[str] | None = None) -> int:
    """Parse the command line, run the rounds, print the figures and ratios."""
    parser = argparse.ArgumentParser(
        description=(__doc__ or "").split("\n\n")[0],
        usage="%(prog)s [options] before after -- command",
    )
    parser.add_argument("before", type=Path, help="checkout before the change (with .venv)")
    parser.add_argument("after", type=Path, help="checkout after the change (with .venv)")
    parser.add_argument("--rounds", type=int, default=5, help="rounds (each runs both once)")
    parser.add_argument(
        "--figure", action="append", required=True, help="regex; its first group is the figure"
    )
    parser.add_argument("--tolerance", type=float, default=0.05, help="|after/before - 1| bound")
    parser.add_argument("--timeout", type=float, default=None, help="seconds per run")
    given = list(sys.argv[1:] if argv is None else argv)
    split = given.index("--") if "--" in given else len(given)
    args = parser.parse_args(given[:split])
    command = given[split + 1 :]
    if not command or args.rounds < 1:
        parser.error("give --rounds >= 1 and the command after --")
    patterns = [re.compile(text) for text in args.figure]
    names = [name_of(p, i) for i, p in enumerate(patterns)]
    sides = (Checkout("before", args.before.resolve()), Checkout("after", args.after.resolve()))
    for side in sides:
        if not side.python.exists():
            parser.error(f"{side.label}: no {side.python}")
    print(f"before  {sides[0].directory}\nafter   {sides[1].directory}")
    print(f"command {' '.join(command)}\n")
    seen: dict[str, list[list[float]]] = {"before": [], "after": []}
    for round_index in range(args.rounds):
        order = sides if round_index % 2 == 0 else sides[::-1]
        for side in order:
            values = figures_of(run_once(side, command, args.timeout), patterns)
            seen[side.label].append(values)
            shown = "  ".join(f"{n} {v:g}" for n, v in zip(names, values, strict=True))
            print(f"round {round_index + 1}  {side.label:<6}  {shown}", flush=True)
    print()
    within = True
    for i, name in enumerate(names):
        before = statistics.median(v[i] for v in seen["before"])
        after = statistics.median(v[i] for v in seen["after"])
        ratio = after / before if before else float("nan")
        ok = abs(ratio - 1.0) <= args.tolerance
        within = within and ok
        print(
            f"{name}: median before {before:g}, after {after:g}; after/before {ratio:.4f} "
            f"({100 * (ratio - 1):+.1f} %), within {100 * args.tolerance:g} %: "
            f"{'yes' if ok else 'NO'}"
        )
    return 0 if within else 1


if __name__ == "__main__":
    sys.exit(main())
