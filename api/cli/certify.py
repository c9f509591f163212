"""``rcb certify PLAN``: a Monte Carlo certificate of a plan under an RCB strategy.

Thin over :mod:`supervisor.virtual.certify`: seeded true processes inside the plan's bands, RCB part
by part, the true-limit violations counted, a one-sided 95 % Clopper-Pearson bound on the
per-part violation probability, and MRR/oracle after 1, 5, 10 and ``--parts`` parts; with
``--fault`` on a misbehaving shop floor (:mod:`supervisor.virtual.fault_spec`), violations
split into unavoidable and avoidable ones and a row per fault.

Exit codes: 0 it ran and no part crossed a true limit; 1 it ran and some part did (the output
is printed in full first), so a CI job fails on a regression of the safety promise; 2 bad
input, 3 the plan has no robust start, 4 solver failure (:func:`api.cli.common.errors`).
"""

from __future__ import annotations

from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

from api.cli.cluster import cluster_executor
from api.cli.common import JsonOption, StrategyOption, emit, err_console, errors
from api.cli.plan_file import PlanToolsDbOption, file_plan
from api.cli.tables import new_table
from models.bounds import LARGEST_WHOLE
from models.errors import InputError
from supervisor.rcb.strategies import DEFAULT_STRATEGY
from supervisor.virtual.fault_spec import catalogue_help, parse_faults
from supervisor.virtual.sizes import MAX_PARTS, MAX_SCENARIOS

if TYPE_CHECKING:
    from concurrent.futures import Executor

    from supervisor.inputs.plan import Plan
    from supervisor.virtual.certificate import Certificate, CertificateSummary
    from supervisor.virtual.fault_spec import Faults

#: Exit code when the certificate ran and some part crossed a true limit.
VIOLATIONS_FOUND = 1

_out = Console()


_PlanArg = Annotated[Path, typer.Argument(metavar="PLAN.toml", help="The plan file.")]
_ScenariosOption = Annotated[
    int,
    typer.Option(
        "--scenarios",
        min=1,
        max=MAX_SCENARIOS,
        help="True processes drawn inside the bands (seeds SEED..SEED+N-1).",
    ),
]
_PartsOption = Annotated[
    int, typer.Option("--parts", min=1, max=MAX_PARTS, help="Parts made per scenario.")
]
_SeedOption = Annotated[
    int, typer.Option("--seed", min=0, max=LARGEST_WHOLE, help="Seed of the first scenario.")
]
_WearDriftOption = Annotated[
    float,
    typer.Option(
        "--wear-drift",
        help="Rise of force, roughness and spindle current over an edge's life "
        "(0.2: +20 %); edges change after parts_per_edge parts. The same as "
        "--fault wear:D.",
    ),
]
_FaultOption = Annotated[
    list[str] | None,
    typer.Option(
        "--fault",
        metavar="KIND[:ARGS]",
        help="A fault of the shop floor, repeatable: " + catalogue_help() + ".",
    ),
]
_JobsOption = Annotated[
    int | None,
    typer.Option(
        "--jobs", min=1, help="Worker processes (default: the CPUs available; 1: no pool)."
    ),
]
_SchedulerOption = Annotated[
    str | None,
    typer.Option(
        "--scheduler",
        metavar="ADDRESS",
        help="A Dask scheduler (tcp://HOST:8786) whose workers run the scenarios instead of "
        "local processes; the same certificate (needs the cluster extra).",
    ),
]


def certify(
    plan_file: _PlanArg,
    strategy: StrategyOption = DEFAULT_STRATEGY,
    scenarios: _ScenariosOption = 200,
    parts: _PartsOption = 30,
    seed: _SeedOption = 0,
    wear_drift: _WearDriftOption = 0.0,
    fault: _FaultOption = None,
    jobs: _JobsOption = None,
    scheduler: _SchedulerOption = None,
    db: PlanToolsDbOption = None,
    as_json: JsonOption = False,
) -> None:
    """Monte Carlo certificate of a plan under an RCB strategy (violations, MRR).

    Per scenario a true process is drawn inside the plan's bands; RCB starts
    from the robust optimum and makes --parts parts, each measured with noise
    and reported back; a scenario whose bands leave no safe setpoint stops.
    Per row k = 1, 5, 10, --parts: the true-limit violations of parts 1..k,
    the parts made, a one-sided 95 % Clopper-Pearson upper bound on the
    probability that a part crosses a true limit, and MRR/oracle (mean, p5).
    Violations are split into unavoidable (a scenario's first part, the first
    part after a step fault) and avoidable ones, with a bound on the latter;
    with --fault, a row per fault says what it did.

    Exit code 0 when no part crossed a true limit, 1 when some did (after
    printing everything, JSON included), so a CI job fails on it; 2 bad input,
    3 no robust start, 4 solver failure.
    """
    with errors():
        summary = _certified(
            plan_file,
            strategy,
            scenarios=scenarios,
            parts=parts,
            seed=seed,
            wear_drift=wear_drift,
            fault=fault or [],
            jobs=jobs,
            scheduler=scheduler,
            db=db,
            as_json=as_json,
        )
    if as_json:
        emit(summary_json(summary))
    else:
        _print_summary(summary)
    if summary.violations:
        raise typer.Exit(VIOLATIONS_FOUND)


def _certified(
    plan_file: Path,
    strategy: str,
    *,
    scenarios: int,
    parts: int,
    seed: int,
    wear_drift: float,
    fault: list[str],
    jobs: int | None,
    scheduler: str | None,
    db: str | None,
    as_json: bool,
) -> CertificateSummary:
    """The options checked, the plan loaded and certified (a progress bar on a terminal)."""
    # imported here (NumPy, SciPy, the solvers): rcb --help and the other commands do not load them
    from models import fields
    from supervisor.virtual.certificate import summarize
    from supervisor.virtual.certify import available_cpus

    drift = fields.number(wear_drift, "--wear-drift", minimum=0.0)
    faults = parse_faults(fault, wear_drift=drift, wear_flag="--wear-drift")
    plan = file_plan(plan_file, db)
    if scheduler is not None and jobs is not None:
        why = "not with --scheduler: the cluster's workers run the scenarios"
        raise InputError("--jobs", jobs, why)
    with ExitStack() as stack:
        executor, workers = None, jobs if jobs is not None else available_cpus()
        if scheduler is not None:
            executor, workers = stack.enter_context(cluster_executor(scheduler))
        certificate = _run(
            plan, strategy, scenarios, parts, seed, faults, workers, executor, as_json
        )
    return summarize(certificate)


def _run(
    plan: Plan,
    strategy: str,
    scenarios: int,
    parts: int,
    seed: int,
    faults: Faults,
    workers: int,
    executor: Executor | None,
    as_json: bool,
) -> Certificate:
    """The certificate, with a progress bar on a terminal."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from supervisor.virtual.certify import certify_plan

    with Progress(
        TextColumn(f"certify {plan.name} ({strategy})"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("scenarios"),
        TimeElapsedColumn(),
        console=err_console,
        transient=True,
        disable=as_json or not err_console.is_terminal,
    ) as progress:
        task = progress.add_task("scenarios", total=scenarios)
        certificate = certify_plan(
            plan,
            strategy,
            scenarios=scenarios,
            parts=parts,
            seed=seed,
            faults=faults,
            jobs=workers,
            progress=lambda done: progress.update(task, completed=done),
            executor=executor,
        )
    return certificate


def _print_summary(summary: CertificateSummary) -> None:
    """The tables and notes of the certificate, as plain text around rich tables."""
    title, table, notes = summary_lines(summary)
    _out.print(title, markup=False, highlight=False)
    _out.print(table)
    _out.print(notes, markup=False, highlight=False)
    _out.print(avoidable_line(summary), markup=False, highlight=False)
    if summary.fault_rows:
        _out.print(fault_table(summary))


def summary_json(summary: CertificateSummary) -> dict[str, Any]:
    """The ``--json`` document: totals over every part, MRR/oracle keyed by row (``"k"``)."""
    return {
        "plan": summary.plan,
        "strategy": summary.strategy,
        "scenarios": summary.scenarios,
        "parts": summary.parts,
        "seed": summary.seed,
        "violations": summary.violations,
        "stopped": summary.stopped,
        "violation_probability_upper_95": summary.violation_probability_upper_95,
        "unavoidable_violations": summary.unavoidable_violations,
        "avoidable_violations": summary.avoidable_violations,
        "avoidable_violating_parts": summary.avoidable_violating_parts,
        "avoidable_parts_made": summary.avoidable_parts_made,
        "avoidable_probability_upper_95": summary.avoidable_probability_upper_95,
        "faults": [
            {"fault": t.fault, "what": t.what, "value": t.value, "of": t.of}
            for t in summary.fault_rows
        ],
        "mrr_over_oracle": {
            str(r.after_parts): {"mean": r.mrr_over_oracle_mean, "p5": r.mrr_over_oracle_p5}
            for r in summary.rows
        },
    }


def summary_lines(summary: CertificateSummary) -> tuple[str, Table, str]:
    """Title, one row per ``k`` (parts 1..k of every scenario, MRR/oracle after them), notes.

    The table is 62 columns wide; the title and notes are plain text wrapped at the console.
    """
    last = summary.seed + summary.scenarios - 1
    title = (
        f"{summary.plan}: {summary.strategy}, {summary.scenarios} scenarios "
        f"(seeds {summary.seed}..{last}) x {summary.parts} parts"
    )
    if summary.faults:
        title += ", faults " + " ".join(summary.faults)
    table = new_table()
    headings = (
        "after k\nparts",
        "true-limit\nviolations",
        "parts\nmade",
        "P <=\n(95 %)",
        "MRR/oracle\nmean",
        "MRR/oracle\np5",
    )
    for heading in headings:
        table.add_column(heading, justify="right")
    for r in summary.rows:
        table.add_row(
            str(r.after_parts),
            str(r.violations),
            str(r.parts_made),
            f"{r.violation_probability_upper_95:.3g}",
            f"{r.mrr_over_oracle_mean:.3f}",
            f"{r.mrr_over_oracle_p5:.3f}",
        )
    notes = (
        f"Scenarios stopped (no safe setpoint): {summary.stopped}. P <=: one-sided 95 % "
        "Clopper-Pearson upper bound on the probability that a part crosses a true limit, "
        "from parts 1..k. MRR/oracle: oracle cycle / cycle of the setpoints in force after k "
        "parts; p5: 5th percentile over scenarios."
    )
    return title, table, notes


def avoidable_line(summary: CertificateSummary) -> str:
    """Unavoidable and avoidable violations, and the bound on avoidable violating parts."""
    return (
        f"Violations: {summary.unavoidable_violations} unavoidable (a scenario's first part, "
        f"the first part after a step), {summary.avoidable_violations} avoidable; "
        f"{summary.avoidable_violating_parts} of {summary.avoidable_parts_made} parts at "
        f"avoidable positions crossed a true limit, P <= "
        f"{summary.avoidable_probability_upper_95:.3g} (95 %)."
    )


def fault_table(summary: CertificateSummary) -> Table:
    """One row per fault: its spec, what it did, and out of how many (or of what maximum)."""
    table = new_table("fault", "what it did")
    table.add_column("value", justify="right")
    for t in summary.fault_rows:
        value = f"{t.value:g} of {t.of:g}" if t.combine == "sum" else f"{t.value:.3g}/{t.of:g}"
        table.add_row(t.fault, t.what, value)
    return table
