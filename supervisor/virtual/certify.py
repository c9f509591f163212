r"""A Monte Carlo certificate of a plan under an RCB strategy: closed loop on virtual machines.

For every scenario seed ``s`` in ``seed .. seed + N − 1``:

1. a true process is drawn inside the plan's model bands over the bounds box,
   ``machine = sample_machine(plan, s, wear_drift_per_edge_life=D)``
   (:mod:`supervisor.virtual.simulate`);
2. the *oracle* is the same optimisation with the true models and no band,
   ``optimize_plan(plan, tools=oracle_tools(machine))``: the fastest any controller could run
   without crossing a true limit;
3. RCB starts from the robust optimum, ``start(plan, RcbSettings(strategy=...))``, and makes
   ``K`` parts: each with the setpoints in force (:func:`supervisor.virtual.simulate.run_part`,
   measurement noise from ``numpy.random.default_rng(s)``), its true-limit violations are
   counted, and its measurements go back through :func:`supervisor.rcb.update.update` with each
   edge's age (``edge_parts``, for the operations with a ``parts_per_edge`` limit, whose edges
   are changed after that many parts). When ``update`` leaves no safe setpoint (it returns a
   halted state) the scenario *stops*: it makes no more parts and removes no material (MRR 0)
   from then on.

Row ``k`` of a scenario is "after k parts": the setpoints in force after ``k`` part reports,
those part ``k + 1`` is made with (``k = 0``: the robust start, ``k = K``: the final
setpoints). MRR/oracle of the plan is ``oracle cycle time / cycle time`` (the time-weighted
MRR ratio); per operation it is ``MRR / oracle MRR``.

The certificate itself, its summary (the Clopper-Pearson bound [1]_) and its digest are in
:mod:`supervisor.virtual.certificate`.

A scenario depends only on its seed and results are kept in seed order, so a certificate (and
its :func:`~supervisor.virtual.certificate.digest`) is the same for any ``jobs``. With
``jobs > 1`` the scenarios run in a :class:`~concurrent.futures.ProcessPoolExecutor`; the
robust start of each strategy is computed once, here, and handed to the workers (``start`` is
deterministic, ``RcbState`` immutable).

With wear drift (``D > 0``) each operation's edge is changed after ``floor(parts_per_edge)``
parts, the count its tool-life limit promises, and never within the run for an operation
without that limit; drift applies only where the tool has a tool-life model
(:func:`supervisor.virtual.simulate.run_part`).

With faults (:mod:`supervisor.virtual.fault_spec`, applied by
:mod:`supervisor.virtual.faults`) the machine misbehaves as the catalogue says; the oracle of
row ``k`` is the one of the truth part ``k + 1`` is made with (after a step, the stepped
truth's; with curvature, the curved truth's: :mod:`supervisor.virtual.fault_oracle`), and
violations are judged on the faulted truth. A violation at part 1 or at the first part made
with a step in force is *unavoidable* (no controller knew), every other one *avoidable*.

References
----------
.. [1] Clopper & Pearson (1934), "The use of confidence or fiducial limits illustrated in the
   case of the binomial", Biometrika 26(4), 404-413.
.. [2] Ivester & Heigel (NIST), "Adaptive Control Optimization"; Ivester, Danai & Malkin
   (1997), "Cycle-Time Reduction in Machining by Recursive Constraint Bounding".
"""

from __future__ import annotations

import math
import os
import signal
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any, cast

from models.errors import InputError
from supervisor.errors import SupervisorError
from supervisor.inputs.plan import Plan
from supervisor.rcb.state import RcbSettings, RcbState
from supervisor.rcb.strategies import STRATEGY_NAMES
from supervisor.rcb.update import start
from supervisor.virtual import sizes
from supervisor.virtual.certificate import Certificate, ScenarioTrace
from supervisor.virtual.fault_spec import Faults, with_wear
from supervisor.virtual.scenario import run_scenario

#: The most scenarios and parts per scenario a certificate runs.
MAX_SCENARIOS = sizes.MAX_SCENARIOS
MAX_PARTS = sizes.MAX_PARTS

#: ``progress(done)``: called with the number of scenarios finished so far.
Progress = Callable[[int], None]


# --------------------------------------------------------------------------- many scenarios

#: At most this many scenarios per task: the progress moves, and Ctrl-C waits for little.
_MAX_CHUNK = 8
#: Per worker process: the robust start of each strategy and the faults (_init_worker).
_WORKER: dict[str, Any] = {}


def _init_worker(starts: Mapping[str, RcbState], faults: Faults) -> None:
    # Ctrl-C is the parent's to handle: it cancels what is queued, the workers finish theirs
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _WORKER["starts"] = dict(starts)
    _WORKER["faults"] = faults


def _worker_scenario(task: tuple[str, int, int]) -> ScenarioTrace | None:
    """One scenario in a worker (:func:`_in_worker`), its start the pool's."""
    strategy, seed, parts = task
    return _in_worker(_WORKER["starts"][strategy], seed, parts, _WORKER["faults"])


def _scenarios_task(
    task: tuple[RcbState, tuple[int, ...], int, Faults],
) -> list[ScenarioTrace | None]:
    """Some scenarios on an executor the caller gave (a cluster's): the start travels along."""
    initial, seeds, parts, faults = task
    return [_in_worker(initial, seed, parts, faults) for seed in seeds]


def _in_worker(initial: RcbState, seed: int, parts: int, faults: Faults) -> ScenarioTrace | None:
    """One scenario away from the caller; None where it raised a domain error.

    Those carry structured arguments and do not survive pickling back to the parent; the
    parent runs the (deterministic) scenario again and raises the error itself.
    """
    try:
        return run_scenario(initial, seed, parts, faults=faults)
    except (InputError, SupervisorError):
        return None


def _chunk(scenarios: int, jobs: int) -> int:
    """Scenarios per task: about 8 tasks per worker, at most :data:`_MAX_CHUNK` each."""
    return min(_MAX_CHUNK, max(1, scenarios // (8 * jobs)))


def available_cpus() -> int:
    """The CPUs this process may run on (the default number of worker processes)."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return os.cpu_count() or 1


def _check(
    strategies: Sequence[str], seed: int, scenarios: int, parts: int, drift: float, jobs: int
) -> None:
    for strategy in strategies:
        if strategy not in STRATEGY_NAMES:
            known = ", ".join(STRATEGY_NAMES)
            raise InputError("strategy", strategy, f"expected one of: {known}")
    checks = (
        ("scenarios", scenarios, 1, MAX_SCENARIOS),
        ("parts", parts, 1, MAX_PARTS),
        ("jobs", jobs, 1, None),
        ("seed", seed, 0, None),
    )
    for name, value, low, high in checks:
        if value < low or (high is not None and value > high):
            span = f"{low}..{high}" if high is not None else f">= {low}"
            raise InputError(name, value, f"must be an integer in {span}")
    if not (math.isfinite(drift) and drift >= 0):
        raise InputError("wear_drift_per_edge_life", drift, "must be a number >= 0")


def simulate(
    plan: Plan,
    strategies: Sequence[str],
    *,
    scenarios: int,
    parts: int,
    seed: int = 0,
    wear_drift_per_edge_life: float = 0.0,
    faults: Faults | None = None,
    jobs: int = 1,
    progress: Progress | None = None,
    executor: Executor | None = None,
) -> tuple[Certificate, ...]:
    """Run the same scenarios under each strategy (one worker pool for all of them).

    Parameters
    ----------
    plan, strategies : Plan, Sequence[str]
        The plan; names of :data:`supervisor.rcb.strategies.STRATEGY_NAMES`, in this order.
    scenarios, parts, seed : int
        Scenarios per strategy (``1..MAX_SCENARIOS``, seeds ``seed .. seed + scenarios − 1``),
        parts per scenario (``1..MAX_PARTS``), the first seed (``>= 0``).
    wear_drift_per_edge_life : float
        Relative rise of force, roughness and spindle current over an edge's life [-]; the
        alias of the fault ``wear:D`` (an error beside another ``wear`` value).
    faults : Faults, optional
        The faults of the shop floor, e.g. ``parse_faults(["dropout:0.1", "step"])``
        (:mod:`supervisor.virtual.fault_spec`); none by default.
    jobs : int
        Worker processes (1: every scenario in this process; never more than ``scenarios``).
    progress : callable, optional
        Called with the number of scenarios finished so far (over all strategies).
    executor : Executor, optional
        Where the scenarios run instead of a pool of ``jobs`` processes (a Dask cluster's,
        ``distributed.Client.get_executor()``: :func:`api.cli.cluster.cluster_executor`);
        ``jobs`` then sizes the tasks (about 8 per worker). The caller owns and closes it.

    Returns one certificate per strategy, in the order given, the same for any ``jobs`` or
    ``executor``. Raises :class:`InputError` (an unknown strategy or a count out of range,
    naming it) and :class:`InfeasibleError` (no robust start).
    """
    _check(strategies, seed, scenarios, parts, wear_drift_per_edge_life, jobs)
    shop = with_wear(faults or Faults(), wear_drift_per_edge_life)
    starts = _starts(plan, strategies)
    seeds = range(seed, seed + scenarios)
    jobs = min(jobs, scenarios)
    if executor is not None:
        run = _Run(seeds, parts, shop, executor, jobs, carried=True)
        return _certificates(plan, strategies, starts, run, progress)
    pool = _pool(jobs, starts, shop)
    try:
        run = _Run(seeds, parts, shop, pool, jobs, carried=False)
        return _certificates(plan, strategies, starts, run, progress)
    finally:  # on an error or Ctrl-C, drop the scenarios not started instead of running them
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)


def _starts(plan: Plan, strategies: Sequence[str]) -> dict[str, RcbState]:
    """The robust start of each strategy, computed once and handed to the workers."""
    # checked by _check and by RcbSettings; Any: the strategy's type is the registry's business
    return {s: start(plan, RcbSettings(strategy=cast(Any, s))) for s in strategies}


def _pool(jobs: int, starts: Mapping[str, RcbState], shop: Faults) -> Executor | None:
    """A pool of ``jobs`` workers that know the starts and the faults; None for one job."""
    if jobs <= 1:
        return None
    return ProcessPoolExecutor(max_workers=jobs, initializer=_init_worker, initargs=(starts, shop))


@dataclass(frozen=True)
class _Run:
    """Where and how the scenarios run.

    ``pool`` None: here; else a pool of ``jobs`` workers that hold the starts (``carried``
    False), or a caller's executor whose tasks carry them (``carried`` True).
    """

    seeds: range
    parts: int
    shop: Faults
    pool: Executor | None
    jobs: int
    carried: bool


def _certificates(
    plan: Plan,
    strategies: Sequence[str],
    starts: Mapping[str, RcbState],
    run: _Run,
    progress: Progress | None,
) -> tuple[Certificate, ...]:
    """One certificate per strategy, in the order given (:func:`simulate`)."""
    results: list[Certificate] = []
    done = 0
    for strategy in strategies:
        t0 = time.perf_counter()
        made: list[ScenarioTrace] = []
        for trace in _traces(starts[strategy], strategy, run):
            made.append(trace)
            done += 1
            if progress is not None:
                progress(done)
        certificate = Certificate(
            plan=plan.name,
            strategy=strategy,
            seed=run.seeds.start,
            parts=run.parts,
            wear_drift_per_edge_life=run.shop.wear,
            scenarios=tuple(made),
            seconds=time.perf_counter() - t0,
            faults=run.shop,
        )
        results.append(certificate)
    return tuple(results)


def _traces(initial: RcbState, strategy: str, run: _Run) -> Iterator[ScenarioTrace]:
    """The scenarios of ``run.seeds`` under ``strategy`` from ``initial``, in seed order.

    In ``run.pool`` when there is one; a scenario that raised a domain error in a worker
    (None) runs again here, to raise it in this process.
    """
    seeds, parts, shop = run.seeds, run.parts, run.shop
    if run.pool is None:
        for s in seeds:
            yield run_scenario(initial, s, parts, faults=shop)
        return
    done: Iterator[ScenarioTrace | None]
    if run.carried:
        done = _on_executor(initial, seeds, parts, shop, run.pool, run.jobs)
    else:
        tasks = [(strategy, s, parts) for s in seeds]
        done = run.pool.map(_worker_scenario, tasks, chunksize=_chunk(len(seeds), run.jobs))
    for s, trace in zip(seeds, done, strict=True):
        if trace is None:
            trace = run_scenario(initial, s, parts, faults=shop)
        yield trace


def _on_executor(
    initial: RcbState, seeds: range, parts: int, shop: Faults, executor: Executor, jobs: int
) -> Iterator[ScenarioTrace | None]:
    """The scenarios of ``seeds`` on ``executor``, in seed order, a chunk per task."""
    size = _chunk(len(seeds), jobs)
    chunks = [tuple(seeds[i : i + size]) for i in range(0, len(seeds), size)]
    for traces in executor.map(_scenarios_task, [(initial, c, parts, shop) for c in chunks]):
        yield from traces


def certify_plan(
    plan: Plan,
    strategy: str,
    *,
    scenarios: int = 200,
    parts: int = 30,
    seed: int = 0,
    wear_drift_per_edge_life: float = 0.0,
    faults: Faults | None = None,
    jobs: int = 1,
    progress: Progress | None = None,
    executor: Executor | None = None,
) -> Certificate:
    """The Monte Carlo certificate of ``plan`` under one RCB strategy (module docstring).

    Parameters are those of :func:`simulate` with one strategy; pass the result to
    :func:`~supervisor.virtual.certificate.summarize` for the bound and the MRR/oracle rows.
    """
    (certificate,) = simulate(
        plan,
        (strategy,),
        scenarios=scenarios,
        parts=parts,
        seed=seed,
        wear_drift_per_edge_life=wear_drift_per_edge_life,
        faults=faults,
        jobs=jobs,
        progress=progress,
        executor=executor,
    )
    return certificate
