"""What reading a quantity inside the part could add to the fleet prior's first parts (issue 32).

The fleet benchmark (``closed_loop.py --fleet 4``) leaves the new machine's first part at
about 0.89 of its oracle, against issue 32's 0.95; the prior that knows the fleet's law and
spread exactly reaches 0.90 (``docs/benchmarks.md``, "The fleet prior"). The one lever no
prior has is to read the new machine while the part is cut and adapt the rest of the part:
the spindle load shows the cutting force in the cut (adaptive feed control), an on-machine
gauge could show the roughness before the finish is done. This script bounds that lever:
for each scenario's new machine inside the spread (:func:`supervisor.virtual.fleet_scenario.
new_machine_starts`, the benchmark's defaults), the setpoints in force from the fleet prior
after ``k`` part reports are re-optimised with the quantities ``KNOWN`` of every operation
replaced by the machine's truth (no band, no cone), every other quantity still robust. No
reading inside a part can know more than the truth, so each such row is an upper bound of
what adapting to that reading could reach. The ``GAUGED`` rows are what a real gauge's one
reading could reach: the quantities of every operation as the learner holds them after one
more report, whose reading is taken at the setpoints in force with the measuring chain's
noise (what a gauge read on the operation's first stretch would show), the others as after
``k`` reports. MRR/oracle is the oracle's cycle time over the cycle time (``closed_loop.py``'s
plan ratio).

Usage (from the repository root)::

    .venv/bin/python benchmarks/fleet_in_part.py [--scenarios 200] [--jobs N]
        [--seed-offset 0]

200 scenarios take about 3 minutes on 2 cores.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Mapping
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from models.tool import Tool  # noqa: E402
from supervisor.inputs.plan import load_plan  # noqa: E402
from supervisor.optimize.optimizer import optimize_plan  # noqa: E402
from supervisor.optimize.result import PlanResult  # noqa: E402
from supervisor.rcb.cone import Cone  # noqa: E402
from supervisor.rcb.start import learned_cones  # noqa: E402
from supervisor.rcb.state import RcbState  # noqa: E402
from supervisor.virtual.fault_oracle import truth_oracle  # noqa: E402
from supervisor.virtual.fleet_scenario import new_machine_starts  # noqa: E402
from supervisor.virtual.sampling import oracle_tools  # noqa: E402
from supervisor.virtual.scenario import run_machine  # noqa: E402

PLAN = ROOT / "examples" / "ivester_demo_part.toml"
#: The rows: the setpoints in force after k part reports.
ROWS = (0, 1, 3)
#: What is known in the part, by row label (the quantities read there).
KNOWN: dict[str, tuple[str, ...]] = {
    "nothing read in the part": (),
    "force read in the cut": ("force_N",),
    "roughness read before the finish": ("roughness_um",),
    "force and roughness": ("force_N", "roughness_um"),
}
#: What one real reading in the part updates, by row label.
GAUGED: dict[str, tuple[str, ...]] = {
    "roughness gauged once, as read": ("roughness_um",),
    "force and roughness read once": ("force_N", "roughness_um"),
}


def with_models(
    state: RcbState,
    quantities: tuple[str, ...],
    models: Mapping[str, Tool],
    cones: Mapping[str, Mapping[str, Cone]],
) -> PlanResult:
    """``state``'s plan re-optimised with ``quantities`` at ``models`` and under ``cones``.

    Every other quantity keeps ``state``'s model and cone; ``cones`` ({} for the truth: no
    cone) holds those of ``quantities``.
    """
    if not quantities:
        return state.setpoints
    tools = {}
    for op, tool in state.tools.items():
        theirs = models[op].models
        mixed = {q: theirs[q] if q in quantities else m for q, m in tool.models.items()}
        tools[op] = replace(tool, models=mixed)
    now = learned_cones(state)
    kept = {
        op: {q: c for q, c in now.get(op, {}).items() if q not in quantities}
        | {q: c for q, c in cones.get(op, {}).items() if q in quantities}
        for op in state.tools
    }
    return optimize_plan(state.plan, tools, cones=kept)


def scenario(seed: int) -> tuple[bool, list[list[float]]]:
    """(outside the spread, ratio[variant][row]) of scenario ``seed``."""
    starts = new_machine_starts(load_plan(PLAN), seed, machines=4, learn_parts=30)
    states: list[RcbState] = [starts.from_fleet]
    run_machine(
        starts.from_fleet,
        starts.machine,
        seed,
        max(ROWS) + 1,
        noise_seed=starts.noise,
        on_report=lambda before, after: states.append(after),
    )
    oracle = truth_oracle(starts.machine)
    truth = oracle_tools(starts.machine)
    ratios = [
        [
            oracle.cycle_time_min / with_models(states[k], known, truth, {}).cycle_time_min
            for k in ROWS
        ]
        for known in KNOWN.values()
    ] + [
        [
            oracle.cycle_time_min
            / with_models(
                states[k], gauged, states[k + 1].tools, learned_cones(states[k + 1])
            ).cycle_time_min
            for k in ROWS
        ]
        for gauged in GAUGED.values()
    ]
    return starts.outside, ratios


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", type=int, default=200)
    parser.add_argument("--jobs", type=int, default=len(os.sched_getaffinity(0)))
    parser.add_argument("--seed-offset", type=int, default=0)
    args = parser.parse_args(argv)
    seeds = range(args.seed_offset, args.seed_offset + args.scenarios)
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        results = list(pool.map(scenario, seeds))
    inside = np.array([r for outside, r in results if not outside])
    print(
        f"New machines inside the spread: {len(inside)} of {args.scenarios}; "
        "MRR/oracle mean (p5) after k parts"
    )
    print((f"{'':<33}" + "".join(f"{'k=' + str(k):>7}{'':8}" for k in ROWS)).rstrip())
    for v, label in enumerate([*KNOWN, *GAUGED]):
        cells = "".join(
            f"{inside[:, v, i].mean():>7.3f} ({np.percentile(inside[:, v, i], 5):.3f})"
            for i in range(len(ROWS))
        )
        print(f"{label:<33}{cells}")
    print(f"wall {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
