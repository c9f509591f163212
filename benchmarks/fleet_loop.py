"""``benchmarks/closed_loop.py --fleet MACHINES``: a new machine starts from what others learned.

Per scenario (:mod:`supervisor.virtual.fleet_scenario`): a virtual fleet of ``MACHINES``
machines that cut with the plan's tools, each a little differently (a true between-machine
spread of ``ln K``, ``--fleet-spread``); the first ``MACHINES − 1`` make ``--learn-parts``
parts each with ``learn`` from the catalogue; then the last one makes ``--parts`` parts from
the fleet prior (:mod:`supervisor.fleet.prior`) and, with the same noise, from the
catalogue, and once from the prior of a controller that knows the fleet's law and spread
(``known``: the bound of any fleet prior). MRR/oracle is against the new machine's oracle,
column ``k`` the setpoints in force after ``k`` part reports (``k = 0``: the first part's).
Every tenth scenario's new machine lies outside the spread the fleet has seen (``δ = ±3 s``);
its violations are counted apart, and only those at its first part are allowed. The new
machines whose readings let the fleet prior go (:mod:`supervisor.rcb.prior_check`) are
counted, inside and outside the spread, and those whose chains let the fleet's noise prior go
(:mod:`supervisor.rcb.noise_check`). ``--fault`` applies to the new machine alone (its three
runs): ``--fault noise-scale:3`` is a new machine whose instruments are not the fleet's kind.
``--fleet-fault`` applies to the learning machines (the fleet's own shop floor misbehaves: its
readings drop out, its instruments misreport their noise, its process steps or is not a power
law); a plan that halted, or saw a change of its process its readings did not show five
parts on to be a false alarm, is left out of the fleet; both kinds are counted.
``--operation-spread S`` gives each operation of every machine an offset of its own about its
machine's ``ln K`` (its workholding, its overhang), which the fleet learns the spread of where
a machine ran two operations with a tool; ``--new-plan-on known`` starts the new plan on the
first learning machine, with its operations' offsets drawn anew (a new part program on a
machine the fleet knows: its own readings count, its operations are new); ``--learn-plans N``
has each learning machine run N plans, each with its own operations' offsets.

Usage (from the repository root)::

    .venv/bin/python benchmarks/closed_loop.py --fleet 4 [--scenarios 1000] [--parts 30]
        [--learn-parts 30] [--fleet-spread 0.03] [--operation-spread 0]
        [--new-plan-on new|known] [--learn-plans 1] [--new-z Z] [--fault KIND[:ARGS]]
        [--fleet-fault KIND[:ARGS]] [--jobs N] [--seed-offset 0]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence

import numpy as np

from supervisor.inputs.plan import Plan
from supervisor.virtual.fault_spec import Faults
from supervisor.virtual.fleet_scenario import FleetTrace, FleetWorld, simulate_fleet

#: The rows printed: MRR/oracle after k parts.
ROWS = (0, 1, 2, 3, 5, 10, 30)
#: The targets of issue 32 (fleet prior): at the first part, and after 3 parts.
TARGET_FIRST, TARGET_AFTER_3 = 0.95, 0.98


def _ratios(traces: Sequence[FleetTrace], which: str) -> np.ndarray:
    return np.array([getattr(t, which).plan_ratio for t in traces])


def _violations(traces: Sequence[FleetTrace], which: str) -> tuple[int, int, int]:
    """(at the first part, at the first part after a step, later) over ``traces``.

    The first part after a step of the truth (``--fault step``) is unavoidable: no reading
    has shown the step yet (``ScenarioTrace.unavoidable_at``).
    """
    first = at_step = later = 0
    for t in traces:
        trace = getattr(t, which)
        for p, _, _ in trace.where:
            if p == 1:
                first += 1
            elif p in trace.unavoidable_at:
                at_step += 1
            else:
                later += 1
    return first, at_step, later


def _met(flag: bool) -> str:
    return "met" if flag else "NOT met"


def report(traces: Sequence[FleetTrace], parts: int, seconds: float) -> list[str]:
    """The printed lines (module docstring)."""
    inside = [t for t in traces if not t.outside]
    outside = [t for t in traces if t.outside]
    rows = [k for k in ROWS if k <= parts]
    out: list[str] = []
    for title, cell in (("mean", np.mean), ("p5", lambda r: np.percentile(r, 5))):
        out.append(f"{'MRR/oracle, ' + title:<18}" + "".join(f"{'k=' + str(k):>7}" for k in rows))
        for which in ("fleet", "catalogue", "known"):
            for label, chosen in (("all", traces), ("inside", inside)):
                r = _ratios(chosen, which)
                cells = "".join(f"{float(cell(r[:, k])):>7.3f}" for k in rows)
                out.append(f"{which + ' ' + label:<18}{cells}")
    out.append("  (k: part reports the setpoints follow; inside: new machines inside the spread)")
    if any(t.fleet.unavoidable_at != (1,) for t in traces):
        out.append("  (violations: at part 1, at the first part after a step, later)")
    for which in ("fleet", "catalogue", "known"):
        first_in, step_in, later_in = _violations(inside, which)
        first_out, step_out, later_out = _violations(outside, which)
        steps_in = f"{step_in} at a step, " if step_in else ""
        steps_out = f"{step_out}, " if step_out else ""
        out.append(
            f"{which + ' violations':<20} inside: {first_in} at part 1, {steps_in}{later_in} "
            f"later; outside: {first_out}, {steps_out}{later_out}"
        )
    for label, chosen in (("inside", inside), ("outside", outside)):
        let_go = [t.let_go for t in chosen if t.let_go]
        out.append(
            f"fleet prior let go ({label}): {len(let_go)} of {len(chosen)} new machines, "
            f"{sum(let_go)} quantities"
        )
    for label, chosen in (("inside", inside), ("outside", outside)):
        noise = [t.noise_let_go for t in chosen if t.noise_let_go]
        out.append(
            f"noise prior let go ({label}): {len(noise)} of {len(chosen)} new machines, "
            f"{sum(noise)} chains"
        )
    learned = sum(t.learned_violations for t in traces)
    out.append(f"learning machines (catalogue start): {learned} violations")
    left_out = sum(t.left_out for t in traces)
    if left_out:
        out.append(f"learning plans left out of the fleet (a halt, a change): {left_out}")
    unconfirmed = sum(t.unconfirmed for t in traces)
    if unconfirmed:
        out.append(f"learning plans in, a change their readings do not confirm: {unconfirmed}")
    spreads = [p.spread for t in traces for p in t.provenance]
    if spreads:
        out.append(
            f"spread learned: median {100 * float(np.median(spreads)):.2f} %, "
            f"p5-p95 {100 * float(np.percentile(spreads, 5)):.2f}-"
            f"{100 * float(np.percentile(spreads, 95)):.2f} %"
        )
    r = _ratios(inside, "fleet")
    first, after3 = float(r[:, 0].mean()), float(r[:, min(3, parts)].mean())
    first_in, _, later_in = _violations(inside, "fleet")
    later_out = _violations(outside, "fleet")[2]
    avoidable = first_in + later_in + later_out
    out += [
        f"target first part >= {TARGET_FIRST}: {first:.3f} {_met(first >= TARGET_FIRST)}",
        f"target after 3 >= {TARGET_AFTER_3}: {after3:.3f} {_met(after3 >= TARGET_AFTER_3)}",
        f"target 0 avoidable violations: {avoidable} {_met(avoidable == 0)}",
    ]
    out.append(f"wall {seconds:.1f} s")
    return out


def run(
    plan: Plan,
    args: argparse.Namespace,
    faults: Faults | None = None,
    fleet_faults: Faults | None = None,
) -> int:
    """Simulate and print (``closed_loop.py`` parsed the arguments; ``--fault``: ``faults``,
    ``--fleet-fault``: ``fleet_faults``)."""
    seeds = range(args.seed_offset, args.seed_offset + args.scenarios)
    t0 = time.perf_counter()
    traces = simulate_fleet(
        plan,
        seeds,
        args.fleet,
        args.parts,
        args.learn_parts,
        min(args.jobs, args.scenarios),
        faults,
        FleetWorld(
            machine_spread=args.fleet_spread,
            fleet_faults=fleet_faults,
            operation_spread=args.operation_spread,
            on_known=args.new_plan_on == "known",
            learn_plans=args.learn_plans,
            spread_mix=args.spread_mix,
            new_z=args.new_z,
        ),
    )
    where = "a new machine" if args.new_plan_on == "new" else "a new plan on machine 0"
    print(
        f"Fleet prior: {plan.name!r}, {args.scenarios} scenarios: {args.fleet - 1} machines\n"
        f"learn {args.learn_parts} parts in each of {args.learn_plans} plan(s), then {where} "
        f"makes {args.parts}; "
        f"true spread {100 * args.fleet_spread:.1f} %"
        + (f", operations {100 * args.operation_spread:.1f} %" if args.operation_spread else "")
        + (f", each tool's x exp({args.spread_mix:g} z)" if args.spread_mix else "")
        + (f"; the new machine's plans at z = {args.new_z:g}" if args.new_z is not None else "")
    )
    if faults:
        print(f"the new machine's faults: {', '.join(faults.specs)}")
    if fleet_faults:
        print(f"the learning machines' faults: {', '.join(fleet_faults.specs)}")
    for line in report(traces, args.parts, time.perf_counter() - t0):
        print(line)
    return 0
