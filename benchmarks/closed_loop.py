"""Closed-loop Monte Carlo benchmark of RCB against the oracle (a script run on demand, not a test).

What it measures. For every scenario ``s`` (seed ``seed_offset + s``) and every strategy
(``ivester``, ``bayes``; :mod:`supervisor.rcb`):

1. a true process is drawn inside the plan's model bands,
   ``machine = sample_machine(plan, seed)`` (:mod:`supervisor.simulate`);
2. the *oracle* is the same optimisation with the true models and no band,
   ``optimize_plan(plan, tools=oracle_tools(machine))``: the fastest any controller could run
   without crossing a true limit;
3. RCB starts from the robust optimum, ``start(plan, RcbSettings(strategy=...))``, and makes
   ``--parts`` parts: each part is made with the current setpoints by ``run_part`` (measurement
   noise from ``numpy.random.default_rng(seed)``, the seed of the machine, as
   :func:`supervisor.demo.run_demo` does), its true-limit violations are counted, and its
   measurements go back through ``update`` as a ``PartReport``. An ``InfeasibleError`` from
   ``update`` (grown bands leave no safe setpoint) stops the machine: the scenario is counted
   as *stopped*, makes no more parts and removes no material (MRR 0) from then on.

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
use); each worker loads the plan and computes the robust start once (``start`` is
deterministic and ``RcbState`` immutable, so every scenario starts from the same state). A
scenario depends only on its seed and results are aggregated in seed order, so the output,
including the printed digest of all per-scenario results, is the same for any ``--jobs``.
The wall time covers the whole simulation: starting the workers (each loads the project
and the plan), the oracle solves and every part; "parts" counts the parts actually made.

Usage (from the repository root)::

    .venv/bin/python benchmarks/closed_loop.py [--scenarios 200] [--parts 30]
        [--strategy ivester|bayes|both] [--plan examples/ivester_demo_part.toml]
        [--jobs N] [--seed-offset 0] [--markdown]

How long it takes: every part costs one plan re-optimisation (about 3 ms of one core in all),
so the default run (200 scenarios x 30 parts x 2 strategies = 12 000 parts) takes about 20 s
on this 2-core machine when the host is quiet, and up to twice that when other work shares the
cores; the time scales with scenarios x parts x strategies / jobs.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import sys
import time
from collections import Counter
from collections.abc import Sequence
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from models import kinematics
from supervisor.errors import InfeasibleError
from supervisor.optimizer import PlanResult, optimize_plan
from supervisor.plan import Plan, load_plan
from supervisor.rcb import STRATEGIES, RcbSettings, RcbState, start, update
from supervisor.report import PartReport
from supervisor.simulate import oracle_tools, run_part, sample_machine

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_PLAN = ROOT / "examples" / "ivester_demo_part.toml"
#: Rows of the main table (those <= --parts), as "after k parts".
ROWS = (0, 1, 2, 3, 5, 10, 15, 20, 30)
#: The issue's targets.
TARGET_FROM_PART = 10
TARGET_MEAN_RATIO = 0.95
TARGET_PARTS = 10_000
TARGET_SECONDS = 30.0
PERCENTILE = 5.0

perf = time.perf_counter


# --------------------------------------------------------------------------- one scenario


@dataclass(frozen=True)
class Scenario:
    """The record of one scenario of one strategy (rows 0..parts, parts 1..parts)."""

    seed: int
    oracle_cycle_min: float
    plan_ratio: np.ndarray  # (parts + 1,) oracle cycle / cycle; 0 once stopped
    op_ratio: np.ndarray  # (parts + 1, operations) MRR / oracle MRR; 0 once stopped
    cycle_min: np.ndarray  # (parts + 1,) cycle time; nan once stopped
    violations: np.ndarray  # (parts,) true-limit violations of part 1..parts
    where: tuple[tuple[int, str, str], ...]  # (part, operation, limit) of every violation
    stopped_at: int  # the part whose report left no safe setpoint; 0 if never stopped
    stopped_op: str
    parts_made: int


#: Per worker process: the plan and the robust start of each strategy (see _init_worker).
_PLAN: Plan | None = None
_START: dict[str, RcbState] = {}


def _init_worker(plan_path: str, strategies: Sequence[str]) -> None:
    """Load the plan and compute the (deterministic) robust start once per worker."""
    global _PLAN
    _PLAN = load_plan(Path(plan_path))
    for strategy in strategies:
        _START[strategy] = start(_PLAN, RcbSettings(strategy=strategy))  # type: ignore[arg-type]


def _record(result: PlanResult, oracle: PlanResult) -> tuple[float, np.ndarray, float]:
    """Plan MRR/oracle ratio, per-operation MRR/oracle ratios, cycle time."""
    pairs = zip(result.operations, oracle.operations, strict=True)
    ops = np.array([r.mrr_cm3_min / o.mrr_cm3_min for r, o in pairs])
    cycle = result.cycle_time_min
    return oracle.cycle_time_min / cycle, ops, cycle


def run_scenario(task: tuple[str, int, int]) -> Scenario:
    """Make ``parts`` parts with RCB on the machine of ``seed`` (module docstring)."""
    strategy, seed, parts = task
    assert _PLAN is not None, "worker not initialised"
    plan = _PLAN
    machine = sample_machine(plan, seed=seed)
    oracle = optimize_plan(plan, tools=oracle_tools(machine))
    state = _START[strategy]
    rng = np.random.default_rng(seed)
    n_ops = len(plan.operations)
    plan_ratio = np.zeros(parts + 1)
    op_ratio = np.zeros((parts + 1, n_ops))
    cycle = np.full(parts + 1, np.nan)
    violations = np.zeros(parts, dtype=np.int64)
    where: list[tuple[int, str, str]] = []
    stopped_at, stopped_op, made = 0, "", 0
    for k in range(1, parts + 1):
        plan_ratio[k - 1], op_ratio[k - 1], cycle[k - 1] = _record(state.setpoints, oracle)
        setpoints = {op.name: op.setpoint for op in state.setpoints.operations}
        outcome = run_part(machine, setpoints, rng)
        made = k
        violations[k - 1] = len(outcome.violations)
        where += [(k, v.operation, v.quantity) for v in outcome.violations]
        report = PartReport(f"{seed}-{k}", state.version, outcome.measurements)
        try:
            state, _ = update(state, report)
        except InfeasibleError as err:
            stopped_at, stopped_op = k, err.operation
            break
    if not stopped_at:
        plan_ratio[parts], op_ratio[parts], cycle[parts] = _record(state.setpoints, oracle)
    return Scenario(
        seed=seed,
        oracle_cycle_min=oracle.cycle_time_min,
        plan_ratio=plan_ratio,
        op_ratio=op_ratio,
        cycle_min=cycle,
        violations=violations,
        where=tuple(where),
        stopped_at=stopped_at,
        stopped_op=stopped_op,
        parts_made=made,
    )


# --------------------------------------------------------------------------- aggregation


@dataclass(frozen=True)
class Summary:
    """One strategy over all scenarios, in seed order."""

    strategy: str
    scenarios: tuple[Scenario, ...]
    seconds: float

    @property
    def plan_ratio(self) -> np.ndarray:
        return np.array([s.plan_ratio for s in self.scenarios])

    @property
    def op_ratio(self) -> np.ndarray:
        return np.array([s.op_ratio for s in self.scenarios])

    @property
    def cumulative_violations(self) -> np.ndarray:
        """Row k: violations of parts 1..k over all scenarios (row 0: 0)."""
        per_part = np.array([s.violations for s in self.scenarios]).sum(axis=0)
        return np.concatenate([[0], np.cumsum(per_part)])

    @property
    def parts_made(self) -> int:
        return sum(s.parts_made for s in self.scenarios)

    def mean_cycle(self, row: int) -> tuple[float, int]:
        """Mean cycle time at a row over the scenarios still running, and how many run."""
        values = np.array([s.cycle_min[row] for s in self.scenarios])
        running = values[np.isfinite(values)]
        return (float(running.mean()) if running.size else float("nan")), int(running.size)


def digest(summaries: Sequence[Summary]) -> str:
    """SHA-256 (first 12 hex digits) of every per-scenario array, in order."""
    h = hashlib.sha256()
    for summary in summaries:
        h.update(summary.strategy.encode())
        for s in summary.scenarios:
            for array in (s.plan_ratio, s.op_ratio, s.cycle_min, s.violations):
                h.update(np.ascontiguousarray(array).tobytes())
            h.update(repr((s.oracle_cycle_min, s.where, s.stopped_at, s.stopped_op)).encode())
    return h.hexdigest()[:12]


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


def main_table(summaries: Sequence[Summary], rows: Sequence[int], markdown: bool) -> list[str]:
    stats = []
    for summary in summaries:
        ratio = summary.plan_ratio
        stats.append(
            (
                ratio.mean(axis=0),
                np.percentile(ratio, PERCENTILE, axis=0),
                summary.cumulative_violations,
            )
        )
    if markdown:
        head = "| after k parts |"
        rule = "| ---: |"
        for summary in summaries:
            name = summary.strategy
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
    for summary in summaries:
        head1 += f" {summary.strategy + ' MRR/oracle':^26} |"
        head2 += f" {'mean':>7} {'p5':>7} {'viol':>10} |"
    lines = [head1, head2, "  " + "-" * (len(head2) - 2)]
    for k in rows:
        line = f"  {k:>5} |"
        for mean, p5, viol in stats:
            line += f" {mean[k]:7.3f} {p5[k]:7.3f} {viol[k]:>10d} |"
        lines.append(line)
    return lines


def op_table(summaries: Sequence[Summary], plan: Plan, parts: int) -> list[str]:
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


def violation_lines(summary: Summary) -> list[str]:
    scenarios = summary.scenarios
    total = sum(len(s.where) for s in scenarios)
    hit = sum(1 for s in scenarios if s.where)
    stopped = [s for s in scenarios if s.stopped_at]
    line = (
        f"  {summary.strategy}: {total} true-limit violations in {hit} of {len(scenarios)} "
        f"scenarios; stopped (InfeasibleError) {len(stopped)}"
    )
    lines = [line]
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


def default_jobs() -> int:
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return os.cpu_count() or 1


def simulate(
    executor: Executor | None, strategy: str, seeds: Sequence[int], parts: int, jobs: int
) -> Summary:
    tasks = [(strategy, seed, parts) for seed in seeds]
    t0 = perf()
    if executor is None:
        results = tuple(map(run_scenario, tasks))
    else:
        chunk = max(1, len(tasks) // (8 * jobs))
        results = tuple(executor.map(run_scenario, tasks, chunksize=chunk))
    return Summary(strategy, results, perf() - t0)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenarios", type=int, default=200, help="seeded true processes")
    parser.add_argument("--parts", type=int, default=30, help="parts per scenario")
    parser.add_argument("--strategy", choices=[*STRATEGIES, "both"], default="both")
    parser.add_argument("--plan", type=Path, default=DEFAULT_PLAN, help="plan file (TOML)")
    parser.add_argument(
        "--jobs", type=int, default=default_jobs(), help="worker processes (1: no pool)"
    )
    parser.add_argument("--seed-offset", type=int, default=0, help="scenario s uses seed s + N")
    parser.add_argument(
        "--markdown", action="store_true", help="also print the main table as Markdown"
    )
    args = parser.parse_args(argv)
    if args.scenarios < 1 or args.parts < 1 or args.jobs < 1:
        parser.error("--scenarios, --parts and --jobs must be >= 1")
    strategies = list(STRATEGIES) if args.strategy == "both" else [args.strategy]
    plan = load_plan(args.plan)
    parts = args.parts
    seeds = range(args.seed_offset, args.seed_offset + args.scenarios)
    jobs = min(args.jobs, args.scenarios)
    plan_path = str(args.plan.resolve())

    t0 = perf()
    summaries: list[Summary] = []
    if jobs == 1:
        _init_worker(plan_path, strategies)
        summaries = [simulate(None, s, seeds, parts, jobs) for s in strategies]
    else:
        with ProcessPoolExecutor(
            max_workers=jobs, initializer=_init_worker, initargs=(plan_path, strategies)
        ) as pool:
            summaries = [simulate(pool, s, seeds, parts, jobs) for s in strategies]
    wall = perf() - t0
    made = sum(s.parts_made for s in summaries)
    rate = made / wall

    rows = [k for k in ROWS if k <= parts]
    if parts not in rows:
        rows.append(parts)
    mark = min(TARGET_FROM_PART, parts)
    out: list[str] = []
    out.append(
        f"Closed-loop RCB vs oracle: {plan.name!r} ({len(plan.operations)} operations), "
        f"{args.scenarios} scenarios (seeds {seeds[0]}..{seeds[-1]}) x {parts} parts"
    )
    out.append("MRR/oracle: oracle cycle / cycle of the setpoints in force after k parts (k=0:")
    out.append("robust start); p5: 5th percentile over scenarios; viol: true-limit violations of")
    out.append("parts 1..k, summed over scenarios.")
    out.append("")
    out += main_table(summaries, rows, markdown=False)
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
    out.append("")
    out.append("Targets (from the issue)")
    by_name = {s.strategy: s for s in summaries}
    ivester = by_name.get("ivester")
    if ivester is None:
        out.append("  ivester strategy not run: its targets are not evaluated")
    else:
        viol = int(ivester.cumulative_violations[-1])
        out.append(
            f"  ivester: 0 true-limit violations over all scenarios and parts: {met(viol == 0)} "
            f"({viol})"
        )
        if parts >= TARGET_FROM_PART:
            means = ivester.plan_ratio.mean(axis=0)[TARGET_FROM_PART:]
            ok = bool(means.min() >= TARGET_MEAN_RATIO)
            out.append(
                f"  ivester: mean MRR/oracle >= {TARGET_MEAN_RATIO} from {TARGET_FROM_PART} "
                f"parts on: {met(ok)} ({means[0]:.3f} after {TARGET_FROM_PART}, lowest "
                f"{means.min():.3f} over rows {TARGET_FROM_PART}..{parts})"
            )
        else:
            out.append(f"  ivester: MRR/oracle target needs --parts >= {TARGET_FROM_PART}")
    needed = TARGET_PARTS / TARGET_SECONDS
    out.append(
        f"  speed: {TARGET_PARTS} parts in <= {TARGET_SECONDS:g} s (>= {needed:.0f} parts/s): "
        f"{met(rate >= needed)} ({rate:.0f} parts/s; {TARGET_PARTS} parts would take "
        f"{TARGET_PARTS / rate:.1f} s)"
    )
    print("\n".join(out))
    if args.markdown:
        print()
        print("\n".join(main_table(summaries, rows, markdown=True)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
