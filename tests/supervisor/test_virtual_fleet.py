"""The virtual fleet (issue 32): machines that share a tool's law up to a ln K offset each."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace
from pathlib import Path

import pytest

from supervisor.fleet.provenance import FLEET_VETO_Z
from supervisor.inputs.plan import load_plan
from supervisor.rcb import posterior as post
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start
from supervisor.virtual.fault_spec import parse_faults
from supervisor.virtual.fleet import (
    DEFAULT_MACHINE_SPREAD,
    KNOWN_SD,
    OUTSIDE,
    fleet_truths,
    known_priors,
    machines_of,
    sample_fleet,
    tool_spreads,
)
from supervisor.virtual.fleet_scenario import FleetWorld, run_fleet_scenario
from supervisor.virtual.scenario import run_machine

PLAN = load_plan(Path(__file__).resolve().parents[2] / "examples" / "ivester_demo_part.toml")


def _k(machine, op: str, quantity: str) -> float:  # type: ignore[no-untyped-def]
    return float(machine.processes[op].tool.models[quantity].K)


def test_the_same_seed_draws_the_same_fleet_and_machines_differ_by_ln_K_only() -> None:
    a, b = sample_fleet(PLAN, 5, 3), sample_fleet(PLAN, 5, 3)
    assert a == b
    first, second = a[0].processes["rough-od"].tool, a[1].processes["rough-od"].tool
    for q, model in first.models.items():
        assert second.models[q].exponents == model.exponents
    # two operations of one tool (VCMR331) share the law on a machine: the same K
    assert _k(a[0], "rough-grooves", "force_N") == _k(a[0], "rough-contour", "force_N")


def test_an_outside_machine_sits_at_three_spreads_from_the_fleet() -> None:
    """``δ = ±3 s`` for every tool and quantity with a band (module docstring)."""
    truths = fleet_truths(PLAN, 7, machine_spread=0.02)
    fleet = sample_fleet(PLAN, 7, 2, machine_spread=0.02, outside=True)
    for op in PLAN.operations:
        for q in ("force_N", "roughness_um"):
            ratio = math.log(_k(fleet[-1], op.name, q) / truths[(op.tool, q)].K)
            assert abs(ratio) == pytest.approx(OUTSIDE * 0.02, rel=1e-9)


def test_every_machine_lies_inside_the_catalogue_band_where_it_is_wide_enough() -> None:
    """The catalogue's band holds every machine, an outside one's included, where it is wider
    than the offsets (``ln(1 ± b)`` beyond ``±3 s``); elsewhere within ``e^{±3 s}`` of it."""
    room = OUTSIDE * DEFAULT_MACHINE_SPREAD
    for seed in range(6):
        for machine in sample_fleet(PLAN, seed, 4, outside=True):
            for op in PLAN.operations:
                nominal = PLAN.tools[op.tool]
                true = machine.processes[op.name].tool
                names = list(op.bounds)
                for corner in itertools.product(*(op.bounds[n] for n in names)):
                    point = {**op.context, **dict(zip(names, corner, strict=True))}
                    for q, model in nominal.models.items():
                        if model.dK == 0:
                            continue
                        ratio = true.models[q].predict(point).value / model.predict(point).value
                        band = model.dK / model.K
                        wide = math.log1p(band) > room and math.log1p(-band) < -room
                        low, high = (1 - band, 1 + band)
                        if not wide:
                            low, high = low * math.exp(-room), high * math.exp(room)
                        assert low - 1e-9 <= ratio <= high + 1e-9, (seed, op.name, q)


def test_a_new_machine_starts_faster_from_the_fleet_and_crosses_nothing() -> None:
    """Seed 3: three machines learn 12 parts; the new one's first setpoints from the fleet are
    faster than the catalogue's (0.847 of the oracle), those of a controller that knows the
    fleet's law faster still (0.912), and no run crosses a true limit in 6 parts. The fleet's
    0.907 is that of spreads pooled over the plan's tools; each tool's spread learned from its
    three machines alone gave 0.881 (spreads of 3.9-4.0 % for the true 3 %)."""
    trace = run_fleet_scenario(PLAN, 3, 4, 6, 12)

    assert trace.catalogue.plan_ratio[0] < 0.85 < 0.9 < trace.fleet.plan_ratio[0]
    assert trace.known.plan_ratio[0] > trace.fleet.plan_ratio[0]
    assert trace.fleet.where == trace.catalogue.where == trace.known.where == ()
    assert {p.quantity for p in trace.provenance} == {"force_N", "roughness_um"}
    assert all(p.machines == ("machine-0", "machine-1", "machine-2") for p in trace.provenance)


def test_the_known_prior_is_the_fleets_law_with_the_spread_on_ln_K() -> None:
    """``known_priors``: ``ln Y(c)`` and the exponents of the fleet's truth (posterior.prior of
    it), ``ln Y(c)``'s variance the true spread's, every other parameter known to KNOWN_SD."""
    settings = RcbSettings(strategy="learn")
    truths = fleet_truths(PLAN, 7, 0.02)
    priors = known_priors(PLAN, truths, 0.02, settings)
    op = next(o for o in PLAN.operations if o.name == "rough-od")
    made = priors[("rough-od", "force_N")]
    truth = truths[(op.tool, "force_N")]
    point = {**op.context, **{n: math.exp(c) for n, c in zip(made.names, made.center, strict=True)}}
    assert made.mean[0] == pytest.approx(math.log(truth.predict(point).value), rel=1e-12)
    assert made.mean[1 : 1 + len(made.names)] == pytest.approx(
        [truth.exponents[n] for n in made.names], rel=1e-12
    )
    assert (made.edge_max, made.mean[-1]) == (post.edge_max_of(op, "force_N"), 0.0)
    variances = [made.cov[i][i] for i in range(len(made.mean))]
    assert variances == pytest.approx([0.02**2] + [KNOWN_SD**2] * (len(made.mean) - 1))
    assert set(priors) == {
        (o.name, q) for o in PLAN.operations for q, m in PLAN.tools[o.tool].models.items() if m.dK
    }


ALL = None  # every quantity of the plan


@pytest.mark.parametrize(
    ("spread", "unchecked"),
    [
        # 2 x 3 % under every band of the demonstration plan (rough-od's force, 7 %, the
        # narrowest; examples/ivester_demo_part.toml)
        (0.03, ALL),
        # 2 x 20 % past every band but rough-od's tool life (52 %)
        (0.2, {("rough-od", "tool_life_mm3")}),
    ],
)
def test_the_known_prior_checks_the_band_at_2_sd_where_the_machines_differ_by_more(
    spread: float, unchecked: set[tuple[str, str]] | None
) -> None:
    """The reference applies the fleet prior's veto with the spread known (FLEET_VETO_Z spreads
    past the band's dK/K): without it, on machines 20 % apart, it ran the catalogue's band
    optimum and crossed 230 limits at first parts in 200 scenarios (closed_loop.py --fleet 4
    --fleet-spread 0.2), so it bounded nothing there."""
    truths = fleet_truths(PLAN, 7, spread)
    priors = known_priors(PLAN, truths, spread, RcbSettings(strategy="learn"))
    checked = {key: prior.band_veto_z for key, prior in priors.items() if prior.band_veto_z}
    assert checked == dict.fromkeys(set(priors) - (unchecked or set(priors)), FLEET_VETO_Z)


def test_a_new_machine_far_outside_a_wide_fleet_lets_its_prior_go() -> None:
    """Scenario 49 at a true spread of 6 %: the new machine, 18 % from the fleet, crossed
    finish-od's roughness at parts 1-4 from the fleet prior before the prior check (its first
    reading taught the chain a noise scale ten times its own); with the check, only at part 1,
    the part no controller can know; with each operation's own offset about its machine's
    (hierarchy.DEFAULT_OPERATION_SPREAD) not even there. Its priors are let go, and it still
    runs faster than from the catalogue."""
    trace = run_fleet_scenario(
        PLAN, 49, 4, parts=6, learn_parts=30, world=FleetWorld(machine_spread=0.06)
    )
    assert trace.outside
    assert trace.fleet.where == ()
    assert trace.let_go >= 1
    assert all(trace.fleet.plan_ratio[:4] > trace.catalogue.plan_ratio[:4])
    assert not trace.catalogue.where  # the catalogue's wide roughness band never crossed


def test_a_new_machine_whose_law_bends_crosses_nothing_after_its_first_part() -> None:
    """Scenario 135 with ``--fault curvature`` on the new machine (each operation's law bent
    its own way): with the exponents the fleet's alone, known to a fraction of a per cent,
    the first reading moved rough-od along their force isoline (feed 0.325 to 0.373 mm/rev,
    depth 2.94 to 2.69 mm) and the bent truth crossed 2000 N at part 2; with the exponents'
    between-machine spread (hierarchy.DEFAULT_EXPONENT_SPREAD) nothing crosses."""
    faults = parse_faults(["curvature"])
    trace = run_fleet_scenario(PLAN, 135, 4, parts=4, learn_parts=30, faults=faults)
    assert not trace.outside
    assert trace.fleet.where == trace.catalogue.where == ()


def test_a_fleet_whose_process_stepped_is_left_out_and_the_plan_starts_from_the_catalogue() -> None:
    """``--fleet-fault step:10:1.12``: every learning machine's process rises 12 % at part 10,
    its monitor sees a change and its readings since confirm it (supervisor/fleet/changes.py),
    and a plan whose change is confirmed gives the fleet nothing (as the database leaves it
    out until an engineer puts it back): the new machine's plan from the "fleet" is the
    catalogue's, part for part."""
    clean = run_fleet_scenario(PLAN, 3, 4, parts=3, learn_parts=20)
    assert clean.left_out == clean.unconfirmed == 0 and clean.provenance
    stepped = parse_faults(["step:10:1.12"])
    trace = run_fleet_scenario(
        PLAN, 3, 4, parts=3, learn_parts=20, world=FleetWorld(fleet_faults=stepped)
    )
    assert (trace.left_out, trace.unconfirmed) == (3, 0) and trace.provenance == ()
    assert trace.fleet.plan_ratio.tolist() == trace.catalogue.plan_ratio.tolist()
    assert trace.fleet.plan_ratio[0] < clean.fleet.plan_ratio[0]  # the clean fleet's start


def test_a_false_alarm_on_a_steady_fleet_leaves_the_plan_in() -> None:
    """Seed 5, clean: a learning plan's monitors count a change of a steady process (the
    CUSUM's false alarm), and five parts later its readings do not confirm it: it stays in
    the fleet. Until 2026-12-01 every counted change left its plan out; after 300 parts 57 of
    90 were out and a new machine's first part fell from 0.888 to 0.863 of its oracle. Seed
    21's two plans counted theirs in their last five parts: not judged yet, out."""
    trace = run_fleet_scenario(PLAN, 5, 4, parts=1, learn_parts=30)
    assert (trace.left_out, trace.unconfirmed) == (0, 1)
    assert all(len(p.machines) == 3 for p in trace.provenance)
    late = run_fleet_scenario(PLAN, 21, 4, parts=1, learn_parts=30)
    assert (late.left_out, late.unconfirmed) == (2, 0)


def test_a_fleet_whose_operations_bend_apart_teaches_no_false_slope() -> None:
    """``--fleet-fault curvature``, seed 97: the learning machines' finish-grooves and
    finish-contour (one insert, VPGR3305) bend each its own way; summed as one law per machine
    the fleet read the few per cent between them as a feed exponent of 0.61 ± 0.04 for a true
    1.04, and a new machine crossed finish-contour's roughness at parts 4-6. With each
    operation's own offset (hierarchy.of_operation) nothing crosses, as from the catalogue."""
    bent = parse_faults(["curvature"])
    trace = run_fleet_scenario(
        PLAN, 97, 4, parts=7, learn_parts=30, world=FleetWorld(fleet_faults=bent)
    )
    assert not trace.outside and trace.left_out == 0
    assert trace.fleet.where == trace.catalogue.where == ()
    assert trace.fleet.plan_ratio[3] > trace.catalogue.plan_ratio[3]


def test_a_wear_fault_wears_a_fleet_machine_as_one_drawn_worn() -> None:
    """``--fault wear:0.05`` / ``--fleet-fault wear:0.05``: a fleet's machines are drawn
    without wear, and until 2026-11-30 the fault never reached them (the runs were the clean
    runs, digit for digit). It now wears the machine as one drawn with that wear does."""
    machine = sample_fleet(PLAN, 5, 1)[0]
    catalogue = start(PLAN, RcbSettings(strategy="learn"))
    parts = 12  # rough-od changes its edge every 10 parts: a run past one edge shows its rise
    worn, _ = run_machine(catalogue, machine, 5, parts, faults=parse_faults(["wear:0.05"]))
    drawn, _ = run_machine(catalogue, replace(machine, wear_drift_per_edge_life=0.05), 5, parts)
    clean, _ = run_machine(catalogue, machine, 5, parts)
    assert worn.plan_ratio.tolist() == drawn.plan_ratio.tolist()
    assert worn.plan_ratio.tolist() != clean.plan_ratio.tolist()


def test_a_new_machine_whose_edges_wear_where_the_fleets_did_not_crosses_nothing() -> None:
    """Scenario 2 with ``--fault wear:0.05`` on the new machine: its force rises 5 % over an
    edge's life, the fleet's machines' did not. With the rise the tool's alone (known to a
    fraction of a per cent from 90 parts), rough-od's force crossed 2000 N at parts 5, 8 and
    9, late in the first edge (nearly every scenario: 708 crossings in 90 inside machines);
    with the rise's between-machine spread (hierarchy.DEFAULT_EDGE_SPREAD) nothing crosses,
    as from the catalogue, and the start stays the faster."""
    worn = parse_faults(["wear:0.05"])
    trace = run_fleet_scenario(PLAN, 2, 4, parts=10, learn_parts=30, faults=worn)
    assert not trace.outside
    assert trace.fleet.where == trace.catalogue.where == ()
    assert all(trace.fleet.plan_ratio[:4] > trace.catalogue.plan_ratio[:4])


def test_a_new_plan_on_a_known_machine_takes_the_operations_spread_the_fleet_showed() -> None:
    """``--operation-spread 0.06 --new-plan-on known``, seed 6: every operation sits 6 % (sd)
    about its machine's ``ln K`` (its workholding, its overhang), and a new plan runs on a
    machine the fleet knows. With the operations' spread fixed at the default's 2 %, its
    first part crossed finish-grooves' and finish-contour's roughness (VPGR3305, which each
    learning machine ran in both); learned from how those two differed on each machine
    (hierarchy.operation_spread) neither crosses."""
    trace = run_fleet_scenario(
        PLAN, 6, 4, parts=1, learn_parts=30, world=FleetWorld(operation_spread=0.06, on_known=True)
    )
    assert not trace.outside
    shared = {"rough-grooves", "rough-contour", "finish-grooves", "finish-contour"}
    assert [w for w in trace.fleet.where if w[1] in shared] == []
    assert trace.fleet.plan_ratio[0] > trace.catalogue.plan_ratio[0]


def test_operation_offsets_leave_a_fleet_without_them_as_it_was() -> None:
    """``operation_spread`` 0 draws the machines of before, to the bit; a new plan on a known
    machine runs that machine's laws again (its offsets of ``ln K``), with its own readings'
    noise."""
    truths = fleet_truths(PLAN, 7)
    plain = machines_of(PLAN, truths, 7, 2)
    assert machines_of(PLAN, truths, 7, 2, operation_spread=0.0) == plain
    again = machines_of(PLAN, truths, 7, 1, plan_draw=1)[0]
    assert again == plain[0]
    other = machines_of(PLAN, truths, 7, 1, plan_draw=1, operation_spread=0.06)[0]
    first = machines_of(PLAN, truths, 7, 1, operation_spread=0.06)[0]
    k = {n: p.tool.models["roughness_um"].K for n, p in other.processes.items()}
    k_first = {n: p.tool.models["roughness_um"].K for n, p in first.processes.items()}
    assert k != k_first  # another plan's operations, about the same machine
    assert 0.8 < min(k[n] / k_first[n] for n in k) and max(k[n] / k_first[n] for n in k) < 1.25


def test_a_spread_mix_gives_each_tool_and_quantity_a_spread_of_its_own() -> None:
    """``--spread-mix 0``: the one spread (the fleet as before, to the bit); 0.5: each tool and
    quantity ``s · exp(0.5 z)``, its machines' offsets scaled by it and the known prior's
    variance its square."""
    assert tool_spreads(PLAN, 5, 0.03) == 0.03
    mixed = tool_spreads(PLAN, 5, 0.03, 0.5)
    assert isinstance(mixed, dict)
    assert set(mixed) == {
        (op.tool, q) for op in PLAN.operations for q in PLAN.tools[op.tool].models
    }
    assert len(set(mixed.values())) == len(mixed)
    assert all(abs(math.log(s / 0.03) / 0.5) < 4 for s in mixed.values())
    truths = fleet_truths(PLAN, 5, mixed)
    one = machines_of(PLAN, truths, 5, 2, machine_spread=0.03)[1]
    apart = machines_of(PLAN, truths, 5, 2, machine_spread=mixed)[1]
    for op in PLAN.operations:
        for q, model in PLAN.tools[op.tool].models.items():
            if model.dK == 0:
                continue
            truth = truths[(op.tool, q)].K
            alike = math.log(one.processes[op.name].tool.models[q].K / truth)
            own = math.log(apart.processes[op.name].tool.models[q].K / truth)
            assert own == pytest.approx(alike * mixed[(op.tool, q)] / 0.03, rel=1e-9)
    known = known_priors(PLAN, truths, mixed, RcbSettings(strategy="learn"))
    for (name, q), prior in known.items():
        tool = next(op.tool for op in PLAN.operations if op.name == name)
        assert prior.cov[0][0] == pytest.approx(mixed[(tool, q)] ** 2)
