"""A fleet scenario: machines learn a plan, then a new machine starts it from what they learned.

For a scenario ``seed`` (:func:`run_fleet_scenario`): the fleet of ``machines`` virtual
machines (:func:`supervisor.virtual.fleet.sample_fleet`; every :data:`OUTSIDE_EVERY`-th
scenario's new machine outside the spread); each of the first ``machines − 1`` makes
``learn_parts`` parts with ``learn`` from the catalogue; their posteriors are the fleet
(:mod:`supervisor.fleet.prior`: a plan that halted is left out, and a plan that saw a change of
its process unless its readings judged it a false alarm, :mod:`supervisor.fleet.changes`, as
the database leaves it out until an engineer puts it back); the last machine then makes
``parts`` parts twice with the same noise, once from the fleet prior and once from the
catalogue, each scored against that machine's oracle (:func:`supervisor.virtual.scenario.
run_machine`), and a third time from the prior of a controller that knows the fleet's law and
spread (:func:`supervisor.virtual.fleet.known_priors`): what no fleet prior can better without
crossing more (at machines 20 % apart a fleet start's first part is faster than it, where the
fleet's spread is read too low to check the band, and crosses there).

``operation_spread`` > 0 gives every operation an offset of its own about its machine
(:func:`~supervisor.virtual.fleet.machines_of`); ``on_known`` runs the new plan on the first
learning machine instead (its own readings in the fleet, the plan's operation offsets drawn
anew: a new part program on a machine the fleet knows), never outside; ``learn_plans`` is how
many plans each learning machine runs (each its own operation offsets and noise).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace

from models.powerlaw import PowerLawModel
from supervisor.fleet.changes import JUDGED_AFTER, confirmed, counted, opens_change
from supervisor.fleet.learned import Learned
from supervisor.fleet.noise import noise_priors
from supervisor.fleet.prior import fleet_priors
from supervisor.fleet.provenance import FleetPrior, Provenance
from supervisor.fleet.window import newest_plans
from supervisor.inputs.plan import Plan
from supervisor.rcb.state import RcbSettings, RcbState
from supervisor.rcb.update import start
from supervisor.virtual.certificate import ScenarioTrace
from supervisor.virtual.fault_spec import Faults
from supervisor.virtual.fleet import (
    DEFAULT_MACHINE_SPREAD,
    Spreads,
    fleet_truths,
    known_priors,
    machines_of,
    noise_seed,
    tool_spreads,
)
from supervisor.virtual.machine import VirtualMachine
from supervisor.virtual.scenario import run_machine

#: Every this many scenarios (seeds ``≡ OUTSIDE_EVERY − 1``), the new machine is drawn outside.
OUTSIDE_EVERY = 10


@dataclass(frozen=True)
class FleetTrace:
    """The new machine's run from the fleet prior and from the catalogue, and the fleet."""

    seed: int
    outside: bool
    fleet: ScenarioTrace
    catalogue: ScenarioTrace
    known: ScenarioTrace
    learned_violations: int
    provenance: tuple[Provenance, ...]
    let_go: int = 0  # the new machine's quantities whose fleet prior its readings let go
    noise_let_go: int = 0  # its chains whose fleet noise prior their readings let go
    left_out: int = 0  # the learning machines' plans left out of the fleet (a halt, a change)
    #: the learning machines' plans in the fleet despite a change their readings do not confirm
    unconfirmed: int = 0


def learned_from(state: RcbState, machine: str, plan: str) -> list[Learned]:
    """What one plan's state gives the fleet: nothing after a halt.

    Each operation's posterior, and its evidence on its measuring chain's noise (its
    monitor's, :mod:`supervisor.fleet.noise`). :func:`_learn` decides whether a change its
    monitors counted leaves it out (:class:`_Judged`).
    """
    if state.halt is not None:
        return []
    settings = state.settings
    ops = {op.name: op for op in state.plan.operations}
    out = []
    for (name, quantity), belief in sorted(state.posterior.items()):
        monitor = state.monitors.get((name, quantity))
        out.append(
            Learned(
                machine,
                plan,
                ops[name],
                state.plan.tools[ops[name].tool],
                belief,
                settings.coverage_k,
                settings.exponent_sd,
                settings.edge_sd,
                chain=None if monitor is None else monitor.chain_noise,
            )
        )
    return out


@dataclass(frozen=True)
class Starts:
    """What a scenario's new machine starts from, once the fleet has learned.

    ``plan`` is the plan it runs (on a known machine: renamed to it), ``machine`` the new
    machine, ``noise`` the seed of its readings' noise; ``from_fleet``, ``catalogue`` and
    ``known`` its three starts (:func:`run_fleet_scenario`); ``priors`` the fleet prior per
    (operation, quantity), ``chains`` the fleet's noise prior per quantity; the rest is what
    the learning machines did (:class:`FleetTrace`).
    """

    plan: Plan
    machine: VirtualMachine
    noise: list[int]
    outside: bool
    from_fleet: RcbState
    catalogue: RcbState
    known: RcbState
    priors: dict[tuple[str, str], FleetPrior]
    chains: int
    learned_violations: int
    left_out: int
    unconfirmed: int


@dataclass(frozen=True)
class FleetWorld:
    """How a scenario's fleet is drawn and learns (:func:`run_fleet_scenario`'s options).

    ``machine_spread``: the fleet's true between-machine spread of ``ln K``;
    ``fleet_faults``: the learning machines' faults (None: they run clean), whose plans a
    halt or a change leaves out of the fleet; ``operation_spread``: each operation's true
    offset about its machine's; ``on_known``: the new plan runs on a learning machine, not a
    new one; ``learn_plans``: plans per learning machine; ``spread_mix``: each tool's spread
    its own (:func:`~supervisor.virtual.fleet.tool_spreads`); ``new_z``: the cone's ``z`` of
    the new machine's three starts (None: the default's).
    """

    machine_spread: float = DEFAULT_MACHINE_SPREAD
    fleet_faults: Faults | None = None
    operation_spread: float = 0.0
    on_known: bool = False
    learn_plans: int = 1
    spread_mix: float = 0.0
    new_z: float | None = None


def new_machine_starts(
    plan: Plan, seed: int, machines: int, learn_parts: int, options: FleetWorld = FleetWorld()
) -> Starts:
    """Scenario ``seed``'s fleet learns; its new machine's starts (:func:`run_fleet_scenario`)."""
    outside = not options.on_known and seed % OUTSIDE_EVERY == OUTSIDE_EVERY - 1
    spreads = tool_spreads(plan, seed, options.machine_spread, options.spread_mix)
    truths = fleet_truths(plan, seed, spreads)  # drawn once: the fleet's and the known's
    world = _world(plan, truths, seed, spreads, options.operation_spread)
    fleet = world(machines, outside=outside)
    settings = RcbSettings(strategy="learn")
    catalogue = start(plan, settings)
    plans = [fleet[:-1], *(world(machines - 1, plan_draw=p) for p in range(1, options.learn_plans))]
    learned, violations, (left_out, unconfirmed), halted = _learn(
        catalogue, plans, seed, learn_parts, options.fleet_faults
    )
    new, last = fleet[-1], noise_seed(seed, machines - 1)
    if options.on_known:  # machine 0 again, a new plan's operations
        new = world(1, plan_draw=options.learn_plans)[0]
        plan = replace(plan, machine=replace(plan.machine, name="machine-0"))
    priors = fleet_priors(plan, learned, settings.coverage_k, settings.exponent_sd, halted=halted)
    chains = {q: p.belief for q, p in noise_priors(learned).items()}
    if options.new_z is not None:  # the new machine's plans only: the fleet learned at the default
        settings = replace(settings, z=options.new_z)
        catalogue = start(plan, settings)
    from_fleet = replace(
        start(plan, settings, {k: p.posterior for k, p in priors.items()}), noise_priors=chains
    )
    known = start(plan, settings, known_priors(plan, truths, spreads, settings))
    return Starts(
        plan,
        new,
        last,
        outside,
        from_fleet,
        catalogue,
        known,
        priors,
        len(chains),
        violations,
        left_out,
        unconfirmed,
    )


def run_fleet_scenario(
    plan: Plan,
    seed: int,
    machines: int,
    parts: int,
    learn_parts: int,
    faults: Faults | None = None,
    world: FleetWorld = FleetWorld(),
) -> FleetTrace:
    """One scenario (module docstring) in ``world`` (:class:`FleetWorld`).

    ``faults``: the new machine's (its three runs'); the learning machines' are
    ``world.fleet_faults``.
    """
    s = new_machine_starts(plan, seed, machines, learn_parts, world)
    new, last = s.machine, s.noise
    trace, state = run_machine(s.from_fleet, new, seed, parts, faults=faults, noise_seed=last)
    return FleetTrace(
        seed,
        s.outside,
        trace,
        run_machine(s.catalogue, new, seed, parts, faults=faults, noise_seed=last)[0],
        run_machine(s.known, new, seed, parts, faults=faults, noise_seed=last)[0],
        s.learned_violations,
        tuple(p.provenance for _, p in sorted(s.priors.items())),
        sum(b.prior_widening > 0 for k, b in state.posterior.items() if k in state.priors),
        s.chains - len(state.noise_priors),
        s.left_out,
        s.unconfirmed,
    )


def _world(
    plan: Plan,
    truths: dict[tuple[str, str], PowerLawModel],
    seed: int,
    machine_spread: Spreads,
    operation_spread: float,
) -> Callable[..., tuple[VirtualMachine, ...]]:
    """``world(machines, outside=…, plan_draw=…)``: the scenario's machines (``machines_of``)."""
    return functools.partial(
        machines_of,
        plan,
        truths,
        seed,
        machine_spread=machine_spread,
        operation_spread=operation_spread,
    )


def _learn(
    catalogue: RcbState,
    plans: Sequence[Sequence[VirtualMachine]],
    seed: int,
    parts: int,
    faults: Faults | None,
) -> tuple[list[Learned], int, tuple[int, int], set[str]]:
    """The learning machines' plans from the catalogue: what the fleet learned from them.

    ``plans[p][m]``: machine ``m`` as plan ``p``'s operations meet it (plan 0 with the noise
    of :func:`noise_seed`). Returns ``(learned, violations, (left out, unconfirmed),
    halted)``: their violations, how many plans a halt or a change of their process not
    judged a false alarm left out, how many are in after a change their readings did not
    confirm, and the tools of the halted plans that learned a model of them (as
    :mod:`db.fleet_left_out` counts them).
    """
    learned: list[Learned] = []
    halted: set[str] = set()
    violations = left_out = unconfirmed = 0
    for p, machines in enumerate(plans):
        for m, machine in enumerate(machines):
            noise = noise_seed(seed, m) if p == 0 else [*noise_seed(seed, m), p]
            judged = _Judged(catalogue)
            trace, state = run_machine(
                catalogue, machine, seed, parts, faults=faults, noise_seed=noise, on_report=judged
            )
            violations += int(trace.violations.sum())
            name = f"plan-{m}" if p == 0 else f"plan-{m}-{p}"
            out = judged.pending is not None
            found = [] if out else learned_from(state, f"machine-{m}", name)
            left_out += not found
            if state.halt is not None:
                tools = {op.name: op.tool for op in state.plan.operations}
                halted |= {tools[op] for op, _ in state.posterior}
            unconfirmed += bool(found and judged.unconfirmed)
            learned += found
    # each machine's newest plans, as the database reads them (supervisor.fleet.window)
    return newest_plans(learned), violations, (left_out, unconfirmed), halted


class _Judged:
    """A learning plan's changes as :mod:`db.fleet_changes` judges them.

    A change beyond those accepted is pending from the report that counted it; the
    :data:`~supervisor.fleet.changes.JUDGED_AFTER`-th report after it accepts it unless the
    readings confirm it. ``pending``: the state before the change, while one is pending.
    """

    def __init__(self, catalogue: RcbState) -> None:
        self.catalogue = catalogue
        self.pending: RcbState | None = None
        self.accepted = self.since = 0
        self.unconfirmed = False

    def __call__(self, before: RcbState, after: RcbState) -> None:
        if self.pending is None:
            if opens_change(before, after, self.accepted):
                self.pending, self.since = before, 0
            return
        self.since += 1
        if self.since == JUDGED_AFTER and not _confirmed(self.pending, after, self.catalogue):
            self.pending, self.accepted, self.unconfirmed = None, counted(after), True


def _confirmed(before: RcbState, now: RcbState, catalogue: RcbState) -> bool:
    """Whether ``now`` confirms the change counted after ``before`` (nothing learned: yes)."""
    if before is catalogue:
        return True
    return confirmed(before.posterior, now.posterior)


def _one(task: tuple[Plan, int, int, int, int, Faults | None, FleetWorld]) -> FleetTrace:
    return run_fleet_scenario(*task)


def simulate_fleet(
    plan: Plan,
    seeds: Sequence[int],
    machines: int,
    parts: int,
    learn_parts: int,
    jobs: int = 1,
    faults: Faults | None = None,
    world: FleetWorld = FleetWorld(),
) -> list[FleetTrace]:
    """:func:`run_fleet_scenario` for every seed, in seed order, on ``jobs`` processes."""
    tasks = [(plan, s, machines, parts, learn_parts, faults, world) for s in seeds]
    if jobs <= 1:
        return [_one(t) for t in tasks]
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        return list(pool.map(_one, tasks, chunksize=max(1, len(tasks) // (4 * jobs))))
