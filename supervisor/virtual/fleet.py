r"""A virtual fleet: machines that cut with the same tools, each a little differently.

The truth of a tool's quantity is drawn once per fleet (as :func:`~supervisor.virtual.sampling.
sample_machine` draws one, kept inside the band over the bounds of *every* operation that uses
the tool, so that one law holds for all of them), and each machine ``m`` multiplies it by
``exp(δ_m)``, ``δ_m ~ N(0, s²)`` per tool and quantity, ``s`` the between-machine spread
(:data:`DEFAULT_MACHINE_SPREAD`). This is the hierarchical model of :mod:`supervisor.fleet.
hierarchy`; what the learner does *not* assume is the spread's value: it learns it, from a
default of its own. A machine drawn ``outside`` sits at ``δ = ±3 s`` for every tool and
quantity: further from the fleet than any it has seen. The tool's truth is drawn inside the
catalogue band narrowed by ``3 s`` on each side, so that every machine's, an outside one's
included, lies inside the catalogue's band (the catalogue holds every machine) where the band
is that wide; a narrower band (the 7 % of CNMG432RN's force in Ivester & Heigel's Table 2,
one machine's scatter) holds the tool's law, and other machines may lie outside it by up to
their offset.

With ``operation_spread`` ``s_o`` > 0, each operation ``o`` of machine ``m`` multiplies its
tools' truths by ``exp(γ_{m,o})`` more, ``γ_{m,o} ~ N(0, s_o²)`` per quantity: the operation's
context (its workholding, overhang, coolant) that the fleet models as an offset about its
machine's ``ln K`` and learns the spread of (:func:`supervisor.fleet.hierarchy.
operation_estimates`). ``plan_draw`` numbers a plan: another plan on the same machines draws
other operation offsets about the same machine offsets.

With ``spread_mix`` ``M`` > 0 (:func:`tool_spreads`), each tool and quantity has a spread of
its own, ``s · exp(M z)``, ``z ~ N(0, 1)``: a fleet whose machines differ more for one insert
(a long boring bar, a thin wall) than for another, which a learner that pools its tools'
spreads (:func:`supervisor.fleet.prior.fleet_priors`) does not assume.

The noise of each machine's readings is the plan's ``u`` (:data:`~supervisor.virtual.machine.
DEFAULT_UNCERTAINTY`), drawn from ``numpy.random.default_rng([seed, m])``
(:func:`noise_seed`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from models.powerlaw import PowerLawModel
from models.tool import Tool
from supervisor.fleet.provenance import FLEET_VETO_Z, beyond_band
from supervisor.inputs.plan import Plan
from supervisor.rcb import posterior as post
from supervisor.rcb.state import RcbSettings
from supervisor.virtual.machine import DEFAULT_UNCERTAINTY, TrueProcess, VirtualMachine
from supervisor.virtual.sampling import log_range, true_model

#: The between-machine spread of ``ln K`` the virtual fleet draws [-]: 3 %, the share of a
#: tool's scatter a machine's rigidity and spindle make (smaller than a catalogue band's
#: 10-50 %, which also holds the material's batch-to-batch and the model's error).
DEFAULT_MACHINE_SPREAD = 0.03
#: Where a machine drawn outside the fleet's spread sits, in multiples of the spread.
OUTSIDE = 3.0
#: The sd [-] a known prior (:func:`known_priors`) keeps on what it knows exactly (an exponent,
#: the edge's rise): a belief in information form must be proper.
KNOWN_SD = 1e-4
#: The streams of the fleet's truths and of its machines' offsets, apart from every noise.
_TRUTH_STREAM = 1_000_003
_OFFSET_STREAM = 1_000_033
_OPERATION_STREAM = 1_000_037
_SPREAD_STREAM = 1_000_039

#: The true between-machine spread: one for every tool and quantity, or each its own.
Spreads = float | Mapping[tuple[str, str], float]


def noise_seed(seed: int, machine: int) -> list[int]:
    """The seed of machine ``machine``'s measurement noise in scenario ``seed``."""
    return [seed, machine]


def tool_spreads(plan: Plan, seed: int, machine_spread: float, spread_mix: float = 0.0) -> Spreads:
    """Per tool and quantity, its true spread ``s · exp(M z)`` (module docstring); 0: ``s``."""
    if spread_mix == 0:
        return machine_spread
    rng = np.random.default_rng([seed, _SPREAD_STREAM])
    return {
        (name, q): machine_spread * math.exp(spread_mix * float(rng.standard_normal()))
        for name in sorted({op.tool for op in plan.operations})
        for q in sorted(plan.tools[name].models)
    }


def _of(spreads: Spreads, key: tuple[str, str]) -> float:
    return spreads if isinstance(spreads, float | int) else spreads[key]


def sample_fleet(
    plan: Plan,
    seed: int,
    machines: int,
    *,
    machine_spread: float = DEFAULT_MACHINE_SPREAD,
    outside: bool = False,
    spread: float = 1 / 3,
    exponent_spread: float = 0.05,
) -> tuple[VirtualMachine, ...]:
    """``machines`` virtual machines running ``plan`` (module docstring); the last ``outside``.

    ``spread`` and ``exponent_spread`` are those of the tool's truth, as
    :func:`~supervisor.virtual.sampling.sample_machine` takes them.
    """
    truths = fleet_truths(plan, seed, machine_spread, spread, exponent_spread)
    return machines_of(plan, truths, seed, machines, machine_spread=machine_spread, outside=outside)


def machines_of(
    plan: Plan,
    truths: dict[tuple[str, str], PowerLawModel],
    seed: int,
    machines: int,
    *,
    machine_spread: Spreads = DEFAULT_MACHINE_SPREAD,
    outside: bool = False,
    operation_spread: float = 0.0,
    plan_draw: int = 0,
) -> tuple[VirtualMachine, ...]:
    """:func:`sample_fleet`'s machines around ``truths`` (:func:`fleet_truths` of ``seed``).

    ``operation_spread``, ``plan_draw``: each operation's offset about its machine, and which
    plan's (module docstring).
    """
    rng = np.random.default_rng([seed, _OFFSET_STREAM])
    contexts = np.random.default_rng([seed, _OPERATION_STREAM, plan_draw])
    fleet = []
    for m in range(machines):
        offsets = {}
        for key in truths:
            draw = float(rng.standard_normal())
            last_outside = outside and m == machines - 1
            delta = math.copysign(OUTSIDE, draw) if last_outside else draw
            exact = plan.tools[key[0]].models[key[1]].dK == 0  # a model without a band
            offsets[key] = 0.0 if exact else delta * _of(machine_spread, key)
        gammas = {
            (op.name, q): 0.0
            if model.dK == 0
            else float(contexts.standard_normal()) * operation_spread
            for op in plan.operations
            for q, model in sorted(plan.tools[op.tool].models.items())
        }
        label = f"fleet machine {m} of scenario {seed}"
        fleet.append(_machine(plan, truths, offsets, label, gammas))
    return tuple(fleet)


def fleet_truths(
    plan: Plan,
    seed: int,
    machine_spread: Spreads = DEFAULT_MACHINE_SPREAD,
    spread: float = 1 / 3,
    exponent_spread: float = 0.05,
) -> dict[tuple[str, str], PowerLawModel]:
    """Per (tool, quantity), the law every machine of the fleet of ``seed`` is an offset of."""
    rng = np.random.default_rng([seed, _TRUTH_STREAM])
    truths: dict[tuple[str, str], PowerLawModel] = {}
    for tool_name in sorted({op.tool for op in plan.operations}):
        tool = plan.tools[tool_name]
        ops = [op for op in plan.operations if op.tool == tool_name]
        for quantity in sorted(tool.models):
            model = tool.models[quantity]
            names = sorted(model.exponents)
            ranges = [log_range(names, op) for op in ops]
            box = (np.min([r[0] for r in ranges], 0), np.max([r[1] for r in ranges], 0))
            inner = _inside(model, OUTSIDE * _of(machine_spread, (tool_name, quantity)))
            truths[(tool_name, quantity)] = true_model(
                inner, ops[0], rng, spread, exponent_spread, box=box
            )
    return truths


def known_priors(
    plan: Plan,
    truths: dict[tuple[str, str], PowerLawModel],
    machine_spread: Spreads,
    settings: RcbSettings,
) -> dict[tuple[str, str], post.Posterior]:
    """The prior of a controller that knows the fleet's law and spread and not the machine.

    The reference of any fleet prior (``benchmarks/closed_loop.py --fleet``): ``ln Y(c)`` at the
    fleet's truth with the true spread's variance, every exponent and the edge's rise (none:
    the virtual fleet's edges do not wear) known to :data:`KNOWN_SD`. Where the machines
    differ by more than a quantity's band (``FLEET_VETO_Z`` spreads past ``dK/K``), it checks
    the band's optimum at ``FLEET_VETO_Z`` sd, as a fleet prior whose readings show that
    does (:func:`supervisor.fleet.prior._beyond_band`, here with the spread itself for its
    lower bound): without it the reference ran the band's optimum on machines 20 % apart.
    """
    out = {}
    for op in plan.operations:
        for quantity, model in plan.tools[op.tool].models.items():
            if model.dK <= 0:
                continue
            truth = post.prior(truths[(op.tool, quantity)], op, 1.0, 0.0, settings.edge_sd)
            size = len(truth.mean)
            cov = [[0.0] * size for _ in range(size)]
            for i in range(size):
                cov[i][i] = KNOWN_SD**2
            spread = _of(machine_spread, (op.tool, quantity))
            cov[0][0] = max(spread, KNOWN_SD) ** 2
            known = replace(truth, cov=tuple(tuple(row) for row in cov))
            if beyond_band(spread, model.dK / model.K):  # the fleet's veto, spread known
                known = replace(known, band_veto_z=FLEET_VETO_Z)
            out[(op.name, quantity)] = known
    return out


def _inside(model: PowerLawModel, room: float) -> PowerLawModel:
    """``model`` with a band that keeps a truth moved by up to ``±room`` (ln) inside its own.

    The catalogue's band holds every machine (module docstring).
    """
    if model.dK == 0:
        return model
    band = model.dK / model.K
    high = math.expm1(math.log1p(band) - room)
    low = 1.0 - (1.0 - band) * math.exp(room) if band < 1 else high
    return PowerLawModel(
        model.quantity,
        model.K,
        model.K * max(min(high, low), 0.0),
        dict(model.exponents),
        model.source,
        model.reference,
    )


def _machine(
    plan: Plan,
    truths: dict[tuple[str, str], PowerLawModel],
    offsets: dict[tuple[str, str], float],
    label: str,
    gammas: dict[tuple[str, str], float],
) -> VirtualMachine:
    processes = {}
    for op in plan.operations:
        nominal = plan.tools[op.tool]
        models = {
            q: _offset(truths[(op.tool, q)], offsets[(op.tool, q)] + gammas[(op.name, q)])
            for q in nominal.models
        }
        tool = Tool(
            name=nominal.name,
            process=nominal.process,
            models=models,
            description=f"true process of operation {op.name!r} ({label})",
            material=nominal.material,
            source=f"sampled inside the bands of {nominal.source or nominal.name}",
        )
        processes[op.name] = TrueProcess(op.name, tool)
    return VirtualMachine(plan=plan, processes=processes, uncertainty=dict(DEFAULT_UNCERTAINTY))


def _offset(model: PowerLawModel, delta: float) -> PowerLawModel:
    return PowerLawModel(
        model.quantity,
        model.K * math.exp(delta),
        model.dK,
        dict(model.exponents),
        model.source,
        model.reference,
    )
