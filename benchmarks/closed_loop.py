"""Closed-loop Monte Carlo benchmark of RCB against the oracle (a script run on demand, not a test).

What it measures (the engine is :mod:`supervisor.virtual.certify`, which ``rcb certify`` also runs).
For every scenario ``s`` (seed ``seed_offset + s``) and every strategy (``ivester``,
``bayes``; :mod:`supervisor.rcb.update`):

1. a true process is drawn inside the plan's model bands,
   ``machine = sample_machine(plan, seed, wear_drift_per_edge_life=--wear-drift)``
   (:mod:`supervisor.virtual.simulate`; with drift, an edge is changed after ``parts_per_edge``
   parts);
2. the *oracle* is the same optimisation with the true models and no band,
   ``optimize_plan(plan, tools=oracle_tools(machine))``: the fastest any controller could run
   without crossing a true limit;
3. RCB starts from the robust optimum, ``start(plan, RcbSettings(strategy=...))``, and makes
   ``--parts`` parts: each part is made with the current setpoints by ``run_part`` (measurement
   noise from ``numpy.random.default_rng(seed)``, the seed of the machine, as
   :func:`supervisor.virtual.demo.run_demo` does), its true-limit violations are counted, and its
   measurements go back through ``update`` as a ``PartReport``. When grown bands leave no
   safe setpoint (``update`` raises ``InfeasibleError`` or returns a halted state) the
   machine stops: the scenario is counted as *stopped*, makes no more parts and removes no
   material (MRR 0) from then on.

Row ``k`` of the tables is "after k parts": the setpoints in force after ``k`` part reports,
i.e. those part ``k + 1`` is made with (``k = 0``: the robust start, which made part 1; ``k =
--parts``: the final setpoints). For the whole plan MRR/oracle is ``oracle cycle time / cycle
time`` (the time-weighted MRR ratio); per operation it is ``MRR / oracle MRR``. Printed per row:
mean and 5th percentile (numpy's linear interpolation) over scenarios, and the cumulative count
of true-limit violations of parts ``1..k`` over all scenarios. Then the cycle time of the
catalogue parameters (``catalog_setpoint``, ``volume / MRR``), the robust start, after 10 parts,
at the end and of the oracle; MRR/oracle per operation after 10 parts and at the end; where
violations happened; the wall time and throughput; and the targets from the issue (ivester: no
true-limit violation in any scenario or part, mean MRR/oracle >= 0.95 in every row from 10
parts on; speed: 10 000 simulated parts in <= 30 s, i.e. >= 333 parts/s). The script says
whether each is met and exits 0 either way.

Scenarios run in a ``ProcessPoolExecutor`` (``--jobs``, default: the CPUs this process may
use); the robust start of each strategy is computed once and handed to the workers
(``start`` is deterministic and ``RcbState`` immutable, so every scenario starts from the
same state). A scenario depends only on its seed and results are aggregated in seed order, so
the output, including the printed digest of all per-scenario results, is the same for any
``--jobs``. The wall time covers the whole simulation: starting the workers, the oracle
solves and every part; "parts" counts the parts actually made.

``--fleet MACHINES`` runs the fleet-prior benchmark instead (``benchmarks/fleet_loop.py``:
machines learn a plan, then a new one starts from what they learned).

``--baseline gp`` adds a column for a Gaussian-process controller when
``benchmarks/gp_baseline.py`` exists and scikit-learn imports: its
``run_gp_scenario(plan, seed, parts, wear_drift_per_edge_life)`` on the first
``--gp-scenarios`` seeds (default 50: it is slow), in its own worker pool. The digest covers
the RCB strategies only; the GP column has its own.

``--fault KIND[:ARGS]`` (repeatable) runs the scenarios on a misbehaving shop floor
(:mod:`supervisor.virtual.fault_spec`: dropout, noise-scale, step, curvature, wear; wear alone is
``--wear-drift``): the header lists the faults, MRR/oracle is against the oracle of the current
(stepped, curved) truth, and the violations of each strategy are split into unavoidable (a
scenario's first part, the first part after a step) and avoidable ones.

Usage (from the repository root)::

    .venv/bin/python benchmarks/closed_loop.py [--scenarios 200] [--parts 30]
        [--strategy learn|ivester|bayes|all] [--plan examples/ivester_demo_part.toml]
        [--jobs N] [--seed-offset 0] [--wear-drift 0] [--fault KIND[:ARGS] ...]
        [--baseline gp [--gp-scenarios 50]]
        [--markdown]

How long it takes: every part costs one plan re-optimisation (about 3 ms of one core in all),
so the default run (200 scenarios x 30 parts x 2 strategies = 12 000 parts) takes about 20 s
on this 2-core machine when the host is quiet, and up to twice that when other work shares the
cores; the time scales with scenarios x parts x strategies / jobs (1000 scenarios: about
five times as long).
"""

from __future__ import annotations

import argparse
import hashlib
import importlib.util
import sys
import time
from collections import Counter
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from api.cli.cluster import cluster_executor
from models import kinematics
from models.errors import InputError
from supervisor.inputs.plan import Plan, load_plan
from supervisor.rcb.strategies import DEFAULT_STRATEGY, STRATEGY_NAMES
from supervisor.virtual.certificate import Certificate, digest
from supervisor.virtual.certify import MAX_PARTS, MAX_SCENARIOS, available_cpus
from supervisor.virtual.certify import simulate as simulate_certificates
from supervisor.virtual.fault_spec import catalogue_help, parse_faults
from supervisor.virtual.fleet import DEFAULT_MACHINE_SPREAD

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_PLAN = ROOT / "examples" / "ivester_demo_part.toml"
#: Rows of the main table (those <= --parts), as "after k parts".
ROWS = (0, 1, 2, 3, 5, 10, 15, 20, 30)
#: The issue's targets (issue 15): per strategy, (after k parts, "mean" or "p5", at least).
TARGETS: dict[str, tuple[tuple[int, str, float], ...]] = {
    "learn": ((10, "mean", 0.98), (30, "mean", 0.99), (10, "p5", 0.97)),
    "ivester": ((10, "mean", 0.94),),
}
TARGET_FROM_PART = 10
TARGET_PARTS = 10_000
TARGET_SECONDS = 60.0
PERCENTILE = 5.0
#: Scenarios of the GP baseline by default (a GP fit per part is slow).
GP_SCENARIOS = 50
#: The most machines of ``--fleet``.
MAX_FLEET = 32
#: At most this many plans per learning machine (--learn-plans): above the window of
#: supervisor.fleet.window.PLANS_PER_MACHINE, which the benchmark measures.
MAX_LEARN_PLANS = 30

perf = time.perf_counter

# --------------------------------------------------------------------------- GP baseline


@dataclass(frozen=True)
class Column:
    """One column group of the main table: MRR/oracle per scenario and row, violations."""

    name: str
    ratio: np.ndarray  # (scenarios, parts + 1)
    cumulative_violations: np.ndarray  # (parts + 1,)


def rcb_column(summary: Certificate) -> Column:
    return Column(summary.strategy, summary.plan_ratio, summary.cumulative_violations)


@dataclass(frozen=True)
class GpRun:
    """The GP baseline over its scenarios (benchmarks/gp_baseline.py's GpTrace, stacked)."""

    seeds: range
    ratio: np.ndarray  # (scenarios, parts + 1)
    violations: np.ndarray  # (scenarios, parts)
    seconds: np.ndarray  # (scenarios,) as each trace reports it
    wall: float

    def column(self) -> Column:
        per_part = self.violations.sum(axis=0)
        cumulative = np.concatenate([[0], np.cumsum(per_part)])
        return Column(f"gp ({len(self.seeds)} sc.)", self.ratio, cumulative)

    def digest(self) -> str:
        h = hashlib.sha256()
        for array in (self.ratio, self.violations):
            h.update(np.ascontiguousarray(array, dtype=np.float64).tobytes())
        return h.hexdigest()[:12]


def gp_baseline() -> Callable[..., Any] | str:
    """``run_gp_scenario`` of benchmarks/gp_baseline.py, or why it cannot be used."""
    if not (Path(__file__).parent / "gp_baseline.py").is_file():
        return "benchmarks/gp_baseline.py does not exist"
    if importlib.util.find_spec("sklearn") is None:
        return "scikit-learn does not import"
    sys.path.insert(0, str(Path(__file__).parent))
    try:
        import gp_baseline as module  # type: ignore[import-not-found]
    except ImportError as err:
        return f"benchmarks/gp_baseline.py does not import ({err})"
    finally:
        sys.path.pop(0)
    run = getattr(module, "run_gp_scenario", None)
    if run is None:
        return "benchmarks/gp_baseline.py has no run_gp_scenario"
    return run


_GP: dict[str, Any] = {}


def _gp_init(run: Callable[..., Any], plan: Plan, parts: int, drift: float) -> None:
    _GP.update(run=run, plan=plan, parts=parts, drift=drift)


def _gp_scenario(seed: int) -> tuple[tuple[float, ...], tuple[int, ...], float]:
    trace = _GP["run"](_GP["plan"], seed, _GP["parts"], wear_drift_per_edge_life=_GP["drift"])
    return tuple(trace.mrr_over_oracle), tuple(trace.violations), float(trace.seconds)


def run_gp(
    run: Callable[..., Any], plan: Plan, seeds: range, parts: int, drift: float, jobs: int
) -> GpRun:
    t0 = perf()
    args = (run, plan, parts, drift)
    if jobs == 1:
        _gp_init(*args)
        traces = list(map(_gp_scenario, seeds))
    else:
        with ProcessPoolExecutor(max_workers=jobs, initializer=_gp_init, initargs=args) as pool:
            traces = list(pool.map(_gp_scenario, seeds))
    wall = perf() - t0
    for seed, (ratio, violations, _) in zip(seeds, traces, strict=True):
        if len(ratio) != parts + 1 or len(violations) != parts:
            raise SystemExit(
                f"gp_baseline seed {seed}: mrr_over_oracle has {len(ratio)} values (needs "
                f"{parts + 1}), violations {len(violations)} (needs {parts})"
            )
    return GpRun(
        seeds=seeds,
        ratio=np.array([t[0] for t in traces], dtype=np.float64),
        violations=np.array([t[1] for t in traces], dtype=np.int64),
        seconds=np.array([t[2] for t in traces], dtype=np.float64),
        wall=wall,
    )


# --------------------------------------------------------------------------- aggregation


def catalogue_cycle(plan: Plan) -> float | None:
    """Cycle time of the catalogue parameters, ``Σ volume / MRR`` [min]; None if incomplete."""
    total = 0.0
    for op in plan.operations:
        if not op.catalog_setpoint:
            return None
        mrr = kinematics.mrr_monomial(op.process).evaluate({**op.catalog_setpoint, **op.context})
        total += kinematics.machining_time_min(op.volume_mm3, mrr)
    return total


# --------------------------------------------------------------------------- printing


def pct(value: float, reference: float | None) -> str:
    if reference is None or not np.isfinite(value):
        return "   n/a"
    return f"{100.0 * (value / reference - 1.0):+6.1f} %"


def met(flag: bool) -> str:
    return "MET" if flag else "NOT MET"


def main_table(columns: Sequence[Column], rows: Sequence[int], markdown: bool) -> list[str]:
    stats = []
    for column in columns:
        ratio = column.ratio
        stats.append(
            (
                ratio.mean(axis=0),
                np.percentile(ratio, PERCENTILE, axis=0),
                column.cumulative_violations,
            )
        )
    if markdown:
        head = "| after k parts |"
        rule = "| ---: |"
        for column in columns:
            name = column.name
            head += f" {name} mean MRR/oracle | {name} p5 | {name} violations |"
            rule += " ---: | ---: | ---: |"
        lines = [head, rule]
        for k in rows:
            line = f"| {k} |"
            for mean, p5, viol in stats:
                line += f" {mean[k]:.3f} | {p5[k]:.3f} | {viol[k]} |"
            lines.append(line)
        return lines
    head1 = "  after |"
    head2 = "  parts |"
    for column in columns:
        head1 += f" {column.name + ' MRR/oracle':^26} |"
        head2 += f" {'mean':>7} {'p5':>7} {'viol':>10} |"
    lines = [head1, head2, "  " + "-" * (len(head2) - 2)]
    for k in rows:
        line = f"  {k:>5} |"
        for mean, p5, viol in stats:
            line += f" {mean[k]:7.3f} {p5[k]:7.3f} {viol[k]:>10d} |"
        lines.append(line)
    return lines


def op_table(summaries: Sequence[Certificate], plan: Plan, parts: int) -> list[str]:
    marks = sorted({min(TARGET_FROM_PART, parts), parts})
    head = f"  {'operation':<16}"
    cols = []
    for summary in summaries:
        mean = summary.op_ratio.mean(axis=0)
        p5 = np.percentile(summary.op_ratio, PERCENTILE, axis=0)
        for k in marks:
            head += f" {summary.strategy + ' @' + str(k):>14}"
            cols.append((mean[k], p5[k]))
    lines = [head]
    for i, op in enumerate(plan.operations):
        line = f"  {op.name:<16}"
        for mean, p5 in cols:
            line += f"    {mean[i]:.3f}/{p5[i]:.3f}"
        lines.append(line)
    return lines


def violation_lines(summary: Certificate) -> list[str]:
    scenarios = summary.scenarios
    total = sum(len(s.where) for s in scenarios)
    hit = sum(1 for s in scenarios if s.where)
    stopped = [s for s in scenarios if s.stopped_at]
    line = (
        f"  {summary.strategy}: {total} true-limit violations in {hit} of {len(scenarios)} "
        f"scenarios; stopped (no safe setpoint) {len(stopped)}"
    )
    lines = [line]
    if summary.faults:
        lines.append(
            f"    {summary.unavoidable_violations} unavoidable (part 1, the first part after a "
            f"step), {summary.avoidable_violations} avoidable"
        )
    if stopped:
        ops = Counter(s.stopped_op for s in stopped)
        at = sorted(s.stopped_at for s in stopped)
        lines.append(
            f"    stops at parts {at[0]}..{at[-1]} (median {at[len(at) // 2]}), operations: "
            + ", ".join(f"{op} {n}" for op, n in ops.most_common())
        )
    if total:
        limits = Counter((op, q) for s in scenarios for _, op, q in s.where)
        parts = sorted(p for s in scenarios for p, _, _ in s.where)
        lines.append(
            "    by limit: "
            + ", ".join(f"{op} {q} {n}" for (op, q), n in limits.most_common(4))
            + (" ..." if len(limits) > 4 else "")
        )
        lines.append(
            f"    at parts {parts[0]}..{parts[-1]} (median {parts[len(parts) // 2]}); "
            f"{sum(1 for p in parts if p <= TARGET_FROM_PART)} of them in parts "
            f"1..{TARGET_FROM_PART}"
        )
    return lines


# --------------------------------------------------------------------------- main


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenarios", type=int, default=200, help="seeded true processes")
    parser.add_argument("--parts", type=int, default=30, help="parts per scenario")
    parser.add_argument("--strategy", choices=[*STRATEGY_NAMES, "all"], default="all")
    parser.add_argument("--plan", type=Path, default=DEFAULT_PLAN, help="plan file (TOML)")
    parser.add_argument(
        "--jobs", type=int, default=available_cpus(), help="worker processes (1: no pool)"
    )
    parser.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="a Dask scheduler (tcp://HOST:8786) whose workers run the scenarios (the cluster "
        "extra; --jobs then only sizes the tasks); the same digest as local workers",
    )
    parser.add_argument("--seed-offset", type=int, default=0, help="scenario s uses seed s + N")
    parser.add_argument(
        "--wear-drift",
        type=float,
        default=0.0,
        help="rise of force, roughness and current over an edge's life (0: none); "
        "the same as --fault wear:D",
    )
    parser.add_argument(
        "--fault",
        action="append",
        default=[],
        metavar="KIND[:ARGS]",
        help="a fault of the shop floor, repeatable: " + catalogue_help().replace("%", "%%"),
    )
    parser.add_argument(
        "--baseline", choices=["gp"], help="add a baseline column (benchmarks/gp_baseline.py)"
    )
    parser.add_argument(
        "--gp-scenarios",
        type=int,
        default=GP_SCENARIOS,
        help=f"scenarios of the GP baseline, the first seeds (default {GP_SCENARIOS}: slow)",
    )
    parser.add_argument(
        "--markdown", action="store_true", help="also print the main table as Markdown"
    )
    parser.add_argument(
        "--fleet",
        type=int,
        metavar="MACHINES",
        help="the fleet prior: MACHINES - 1 machines learn, then a new one starts from them "
        "(benchmarks/fleet_loop.py)",
    )
    parser.add_argument(
        "--learn-parts", type=int, default=30, help="--fleet: parts each learning machine makes"
    )
    parser.add_argument(
        "--fleet-spread",
        type=float,
        default=DEFAULT_MACHINE_SPREAD,
        help="--fleet: the true between-machine spread of ln K",
    )
    parser.add_argument(
        "--operation-spread",
        type=float,
        default=0.0,
        help="--fleet: the true spread of each operation's ln K about its machine's (0: none)",
    )
    parser.add_argument(
        "--spread-mix",
        type=float,
        default=0.0,
        help="--fleet: each tool and quantity's true spread is the fleet's x exp(M z), z ~ "
        "N(0, 1) (0: one spread for all)",
    )
    parser.add_argument(
        "--learn-plans",
        type=int,
        default=1,
        help="--fleet: plans each learning machine runs (each its own operations' offsets)",
    )
    parser.add_argument(
        "--new-z",
        type=float,
        default=None,
        help="--fleet: the cone's z of the new machine's three starts, 1 to 100 (default: the "
        "plan's, 4; the learning machines keep it)",
    )
    parser.add_argument(
        "--new-plan-on",
        choices=["new", "known"],
        default="new",
        help="--fleet: the new plan's machine: a new one, or the first learning machine (a new "
        "part program on a machine the fleet knows: its operations' offsets drawn anew)",
    )
    parser.add_argument(
        "--fleet-fault",
        action="append",
        default=[],
        metavar="KIND[:ARGS]",
        help="--fleet: a fault of the learning machines (as --fault, which is the new "
        "machine's), repeatable",
    )
    args = parser.parse_args(argv)
    if args.scenarios < 1 or args.parts < 1 or args.jobs < 1 or args.gp_scenarios < 1:
        parser.error("--scenarios, --parts, --jobs and --gp-scenarios must be >= 1")
    if args.scenarios > MAX_SCENARIOS or args.parts > MAX_PARTS:
        parser.error(f"--scenarios must be <= {MAX_SCENARIOS} and --parts <= {MAX_PARTS}")
    if args.seed_offset < 0:
        parser.error("--seed-offset must be >= 0")
    if not (np.isfinite(args.wear_drift) and args.wear_drift >= 0):
        parser.error("--wear-drift must be a number >= 0")
    try:
        faults = parse_faults(args.fault, wear_drift=args.wear_drift, wear_flag="--wear-drift")
    except InputError as err:
        parser.error(str(err))
    if args.baseline == "gp" and faults.beyond_wear:
        parser.error("--baseline gp: the GP baseline takes wear drift, no other --fault")
    gp_run: Callable[..., Any] | None = None
    if args.baseline == "gp":
        found = gp_baseline()
        if isinstance(found, str):
            parser.error(f"--baseline gp: {found}")
        gp_run = found
    if args.fleet is not None:
        if not (2 <= args.fleet <= MAX_FLEET and 1 <= args.learn_parts <= MAX_PARTS):
            parser.error(f"--fleet must be 2..{MAX_FLEET} and --learn-parts 1..{MAX_PARTS}")
        if not (np.isfinite(args.fleet_spread) and 0 <= args.fleet_spread <= 1):
            parser.error("--fleet-spread must be a number in [0, 1]")
        if not 1 <= args.learn_plans <= MAX_LEARN_PLANS:
            parser.error(f"--learn-plans must be 1..{MAX_LEARN_PLANS}")
        if not (np.isfinite(args.operation_spread) and 0 <= args.operation_spread <= 1):
            parser.error("--operation-spread must be a number in [0, 1]")
        if not (np.isfinite(args.spread_mix) and 0 <= args.spread_mix <= 2):
            parser.error("--spread-mix must be a number in [0, 2]")
        if args.new_z is not None and not (np.isfinite(args.new_z) and 1 <= args.new_z <= 100):
            parser.error("--new-z must be a number in [1, 100] (a plan's z)")
        try:
            fleet_faults = parse_faults(args.fleet_fault)
        except InputError as err:
            parser.error(f"--fleet-fault: {err}")
        sys.path.insert(0, str(Path(__file__).parent))
        import fleet_loop  # type: ignore[import-not-found]

        return int(fleet_loop.run(load_plan(args.plan), args, faults, fleet_faults))
    strategies = list(STRATEGY_NAMES) if args.strategy == "all" else [args.strategy]
    plan = load_plan(args.plan)
    parts = args.parts
    seeds = range(args.seed_offset, args.seed_offset + args.scenarios)
    jobs = min(args.jobs, args.scenarios)

    t0 = perf()
    with ExitStack() as stack:
        executor = None
        if args.scheduler is not None:
            try:
                executor, jobs = stack.enter_context(cluster_executor(args.scheduler))
            except InputError as err:
                parser.error(str(err))
        summaries = simulate_certificates(
            plan,
            strategies,
            scenarios=args.scenarios,
            parts=parts,
            seed=args.seed_offset,
            faults=faults,
            jobs=jobs,
            executor=executor,
        )
    wall = perf() - t0
    made = sum(s.parts_made for s in summaries)
    rate = made / wall
    gp: GpRun | None = None
    if gp_run is not None:
        gp_seeds = range(args.seed_offset, args.seed_offset + args.gp_scenarios)
        gp_jobs = min(args.jobs, args.gp_scenarios)
        gp = run_gp(gp_run, plan, gp_seeds, parts, faults.wear, gp_jobs)
    columns = [rcb_column(s) for s in summaries] + ([gp.column()] if gp is not None else [])

    rows = [k for k in ROWS if k <= parts]
    if parts not in rows:
        rows.append(parts)
    mark = min(TARGET_FROM_PART, parts)
    out: list[str] = []
    out.append(
        f"Closed-loop RCB vs oracle: {plan.name!r} ({len(plan.operations)} operations), "
        f"{args.scenarios} scenarios (seeds {seeds[0]}..{seeds[-1]}) x {parts} parts"
        + (f", wear drift {faults.wear:g} per edge life" if faults.wear else "")
    )
    if faults.beyond_wear:
        out.append("Faults: " + " ".join(faults.specs))
    out.append("MRR/oracle: oracle cycle / cycle of the setpoints in force after k parts (k=0:")
    out.append("robust start); p5: 5th percentile over scenarios; viol: true-limit violations of")
    out.append("parts 1..k, summed over scenarios.")
    out.append("")
    out += main_table(columns, rows, markdown=False)
    out.append("")

    catalogue = catalogue_cycle(plan)
    robust, _ = summaries[0].mean_cycle(0)
    oracle = float(np.mean([s.oracle_cycle_min for s in summaries[0].scenarios]))
    out.append(f"Cycle time per part [min], mean over scenarios ({', '.join(strategies)})")
    cat_text = "n/a (a catalog_setpoint is missing)" if catalogue is None else f"{catalogue:.3f}"
    out.append(f"  {'catalogue':<24} {cat_text:>7}")
    out.append(f"  {'robust start':<24} {robust:7.3f}   {pct(robust, catalogue)} vs catalogue")
    for summary in summaries:
        marks = {mark: f"after {mark} parts", parts: f"final (after {parts})"}
        for k, label in marks.items():
            value, running = summary.mean_cycle(k)
            note = "" if running == args.scenarios else f"  ({running} running)"
            out.append(
                f"  {summary.strategy + ' ' + label:<24} {value:7.3f}   {pct(value, catalogue)} "
                f"vs catalogue   {pct(value, robust)} vs robust{note}"
            )
    out.append(
        f"  {'oracle':<24} {oracle:7.3f}   {pct(oracle, catalogue)} vs catalogue   "
        f"{pct(oracle, robust)} vs robust"
    )
    out.append("")
    out.append("MRR/oracle per operation after k parts, mean/p5")
    out += op_table(summaries, plan, parts)
    out.append("")
    out.append("True-limit violations and stops")
    for summary in summaries:
        out += violation_lines(summary)
    out.append("")
    per_strategy = "; ".join(
        f"{s.strategy} {s.parts_made} parts {s.seconds:.1f} s" for s in summaries
    )
    out.append(
        f"Speed: {made} parts in {wall:.1f} s wall with {jobs} worker process"
        f"{'es' if jobs > 1 else ''} = {rate:.0f} parts/s"
    )
    out.append(f"  ({per_strategy}; the wall time includes the workers' start-up)")
    out.append(f"Digest of all per-scenario results: {digest(summaries)} (same for any --jobs)")
    if gp is not None:
        gp_parts = int(gp.violations.size)
        out.append(
            f"GP baseline: {len(gp.seeds)} scenarios (seeds {gp.seeds[0]}..{gp.seeds[-1]}), "
            f"{gp_parts} parts in {gp.wall:.1f} s wall ({gp_parts / gp.wall:.1f} parts/s), "
            f"{gp.seconds.mean():.2f} s per scenario as it reports; "
            f"{int(gp.violations.sum())} true-limit violations; digest {gp.digest()}"
        )
    out.append("")
    out.append("Targets (issue 15)")
    by_name = {s.strategy: s for s in summaries}

    def row_mean(summary: Any, k: int) -> float:
        return float(summary.plan_ratio[:, k].mean())

    def row_p5(summary: Any, k: int) -> float:
        return float(np.percentile(summary.plan_ratio[:, k], PERCENTILE))

    for name, goals in TARGETS.items():
        summary = by_name.get(name)
        if summary is None:
            out.append(f"  {name}: not run, its targets are not evaluated")
            continue
        viol = int(summary.cumulative_violations[-1])
        out.append(f"  {name}: 0 true-limit violations: {met(viol == 0)} ({viol})")
        for k, kind, goal in goals:
            if k > parts:
                out.append(f"  {name}: {kind} after {k} parts needs --parts >= {k}")
                continue
            value = row_mean(summary, k) if kind == "mean" else row_p5(summary, k)
            out.append(
                f"  {name}: {kind} MRR/oracle after {k} parts >= {goal}: "
                f"{met(value >= goal)} ({value:.3f})"
            )
    default = by_name.get(DEFAULT_STRATEGY)
    if default is not None:
        own = default.parts_made / default.seconds
        out.append(
            f"  speed: {TARGET_PARTS} parts of {DEFAULT_STRATEGY} in <= {TARGET_SECONDS:g} s "
            f"with {jobs} workers: {met(TARGET_PARTS / own <= TARGET_SECONDS)} ({own:.0f} "
            f"parts/s; {TARGET_PARTS} parts would take {TARGET_PARTS / own:.1f} s)"
        )
    print("\n".join(out))
    if args.markdown:
        print()
        print("\n".join(main_table(columns, rows, markdown=True)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
