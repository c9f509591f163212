r"""A new plan's ``learn`` prior from what plans on other machines learned with the same tools.

For every operation and measured quantity of the new plan, the learned posteriors of the same
tool (name, process and work material) and quantity in the fleet's plans are read as evidence
about the tool's law (:mod:`.evidence`), grouped by machine and combined in the hierarchical
model of :mod:`.hierarchy`. The result is mapped back to the operation's own parameters
(``β = T^{-1}(θ − o)``, the inverse of :func:`.evidence.transform`), a wearing quantity's
edge-age coefficient included: the rise over an edge's life is the tool's, learned by the
fleet as its exponents are, each machine's about it (an operation with no edge limit drops
it). On a machine the fleet already holds, that machine's own evidence is added to the
fleet's belief about it (its offset ``δ_m`` is then known as well as its readings show).

Each tool and quantity's spreads (between machines, between a machine's operations) start
from what the plan's other tools and quantities show, and its own machines may raise them
(:func:`_spreads`; :mod:`.hierarchy`, "A plan's tools").

A quantity no plan of the fleet measured with the tool keeps the catalogue prior and says so
(:class:`.provenance.Provenance` with no plans).
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from models.tool import Tool
from supervisor.fleet.evidence import Evidence, in_operation_terms, in_tool_terms
from supervisor.fleet.hierarchy import (
    DEFAULT_OPERATION_SPREAD,
    DEFAULT_SPREAD,
    SPREAD_WEIGHT,
    FleetBelief,
    fleet_belief,
    summed,
)
from supervisor.fleet.learned import Learned, proper, readings_of
from supervisor.fleet.provenance import FLEET_VETO_Z, FleetPrior, Provenance, beyond_band
from supervisor.fleet.spread import (
    best_determined,
    between_estimate,
    lower_bound,
    operation_estimates,
    pooled,
)
from supervisor.inputs.plan import Operation, Plan
from supervisor.rcb import posterior as post
from supervisor.rcb.posterior import Posterior


def same_tool(a: Tool, b: Tool) -> bool:
    """The fleet's key: the tool's name, process and work material."""
    return (a.name, a.process, a.material) == (b.name, b.process, b.material)


def fleet_priors(
    plan: Plan,
    learned: Sequence[Learned],
    coverage_k: float,
    exponent_sd: float,
    edge_sd: float = post.DEFAULT_EDGE_SD,
    default_spread: float = DEFAULT_SPREAD,
    spread_weight: float = SPREAD_WEIGHT,
    halted: Collection[str] = (),
) -> dict[tuple[str, str], FleetPrior]:
    """Per (operation, quantity) of ``plan`` with fleet evidence, its prior (module docstring).

    Each tool's spreads start from those of the plan's other tools (:func:`_spreads`).
    ``halted``: the tools (by name) a plan of which halted after it learned, left out of
    ``learned`` (:func:`_prior`: their priors check the band's optimum at 2 sd).
    """
    settings = _Settings(coverage_k, exponent_sd, edge_sd)
    readings = readings_of(learned)
    pairs: dict[tuple[str, str], _Pair] = {}
    for op in plan.operations:
        tool = plan.tools[op.tool]
        for quantity in tool.models:
            pair = _pair(tool, quantity, op, readings, settings)
            if pair is not None:
                pairs[(op.name, quantity)] = pair
    seen = _spreads(plan.machine.name, pairs, default_spread, spread_weight)
    return {key: _prior(pair, seen[key], pair.key[0] in halted) for key, pair in pairs.items()}


@dataclass(frozen=True)
class ToolBelief:
    """What the fleet learned of a tool's quantity, in the tool's terms ``θ`` (``rcb fleet law``).

    ``names``: the exponents' inputs; ``catalogue``: ``θ``'s mean and covariance under the
    catalogue prior; ``reference``: ``φ``, where the machines' readings pin ``ln Y`` best;
    ``edge_seen``: whether an operation of the fleet had an edge limit (else ``ω`` is the
    catalogue's, untouched).
    """

    names: tuple[str, ...]
    catalogue: tuple[np.ndarray, np.ndarray]
    belief: FleetBelief
    reference: np.ndarray
    provenance: Provenance
    edge_seen: bool


def tool_beliefs(
    tool: Tool,
    learned: Sequence[Learned],
    coverage_k: float,
    exponent_sd: float,
    edge_sd: float = post.DEFAULT_EDGE_SD,
    default_spread: float = DEFAULT_SPREAD,
) -> dict[str, ToolBelief]:
    """Per quantity of ``tool`` with fleet evidence, the fleet's belief about its law.

    What :func:`fleet_priors` gives a plan of ``tool`` alone on a machine the fleet has not
    seen, before the frame of the plan's operation: its spreads from the tool's quantities.
    """
    settings = _Settings(coverage_k, exponent_sd, edge_sd)
    pairs = {}
    readings = readings_of(learned)
    for quantity in tool.models:
        pair = _pair(tool, quantity, None, readings, settings)
        if pair is not None:
            pairs[("", quantity)] = pair
    seen = _spreads("", pairs, default_spread, SPREAD_WEIGHT)  # "": no machine of the fleet
    out = {}
    for key, pair in pairs.items():
        belief, provenance = _fleet(pair, seen[key])
        catalogue = (pair.prior_mean, pair.prior_cov)
        reference = seen[key].machines.reference
        edge_seen = any(item.posterior.edge_max for item in pair.found)
        names = pair.catalogue.names
        out[key[1]] = ToolBelief(names, catalogue, belief, reference, provenance, edge_seen)
    return out


class _Settings(NamedTuple):
    """The catalogue prior's settings (:func:`supervisor.rcb.posterior.prior`)."""

    coverage_k: float
    exponent_sd: float
    edge_sd: float


#: Tool and quantity: the tool's name, process and work material, and the quantity.
_Key = tuple[str, str, str, str]


class _Machines(NamedTuple):
    """A new operation's machine's evidence (None: none), the others', where they pin ``ln Y``."""

    own: Evidence | None
    others: list[Evidence]
    reference: np.ndarray


@dataclass(frozen=True, eq=False)
class _Pair:
    """One operation's quantity: its catalogue prior and the fleet's evidence, by machine."""

    key: _Key
    op: Operation
    catalogue: Posterior
    found: tuple[Learned, ...]
    operations: dict[str, list[Evidence]]
    prior_mean: np.ndarray
    prior_cov: np.ndarray
    prior_information: np.ndarray
    band_rel: float  # the catalogue band's dK/K

    def operation_estimates(self) -> list[tuple[float, int]]:
        """``σ_o``'s estimates: one per machine that ran the tool in two operations or more."""
        n = len(self.catalogue.names)
        ops = list(self.operations.values())
        return operation_estimates(ops, self.prior_mean, self.prior_information, n)

    def machines(self, machine: str, op_spread: float) -> _Machines:
        """``machine``'s evidence (None: none), the others', and where they pin ``ln Y``.

        Each machine's operations integrated over ``op_spread`` (``σ_o``); the point is
        :func:`~supervisor.fleet.spread.best_determined` of the others.
        """
        by_machine = {m: summed(seen, op_spread) for m, seen in self.operations.items()}
        own = by_machine.pop(machine, None)
        others = list(by_machine.values())
        n = len(self.catalogue.names)
        reference = best_determined(others, self.prior_information, n, self.catalogue.center)
        return _Machines(own, others, reference)


def _pair(
    tool: Tool,
    quantity: str,
    op: Operation | None,
    readings: Sequence[tuple[Learned, Evidence | None]],
    settings: _Settings,
) -> _Pair | None:
    """The fleet's evidence about ``tool``'s law of ``quantity``, by machine (None: none usable).

    ``op``: the operation whose frame the catalogue prior is in (None: the first learned one's);
    ``readings``: each learned model with its evidence (:func:`_evidence`).
    """
    model = tool.models[quantity]
    matched = [
        (i, seen)
        for i, seen in readings
        if same_tool(i.tool, tool) and i.posterior.quantity == quantity
    ]
    found = [i for i, _ in matched]
    if model.dK <= 0 or not found:
        return None
    frame = found[0].operation if op is None else op
    coverage_k, exponent_sd, edge_sd = settings
    catalogue = post.prior(model, frame, coverage_k, exponent_sd, edge_sd)
    if not proper(catalogue):  # a parameter known exactly: the catalogue's stands
        return None
    operations: dict[str, list[Evidence]] = {}
    used = []  # what the provenance names and counts: the models whose evidence is in it
    for item, seen in matched:
        if seen is None or item.posterior.names != catalogue.names:
            continue
        operations.setdefault(item.machine, []).append(seen)
        used.append(item)
    if not operations:
        return None
    prior_mean, prior_cov = in_tool_terms(catalogue, frame.context, edge_sd)
    key = (tool.name, tool.process, tool.material, catalogue.quantity)
    p0 = np.linalg.inv(prior_cov)
    band = model.dK / model.K
    return _Pair(key, frame, catalogue, tuple(used), operations, prior_mean, prior_cov, p0, band)


#: A spread's default for one tool and quantity, and the floor its own estimates keep it above.
_Default = tuple[float, float]


class _Seen(NamedTuple):
    """A pair's spreads ``σ_b`` and ``σ_o``, and its machines, each integrated over ``σ_o``.

    ``machines_dof``: the degrees of freedom of the machines' own estimate of ``σ_b`` (0: fewer
    than two machines measured it); ``spread_low``: ``σ_b``'s 95 % lower credible bound.
    """

    spread: float
    operation_spread: float
    machines: _Machines
    machines_dof: int = 0
    spread_low: float = 0.0


def _spreads(
    machine: str, pairs: Mapping[tuple[str, str], _Pair], default_spread: float, weight: float
) -> dict[tuple[str, str], _Seen]:
    """Per pair, ``σ_b`` and ``σ_o``: its own estimates pooled with its tool's defaults.

    ``σ_o``'s first (:func:`_moderated`), then ``σ_b``'s, from the estimates each pair's
    machines give with its own ``σ_o`` (hierarchy, "a plan's tools"). Each pair's estimates
    are made once.
    """
    # the last operation of a tool speaks for its quantity: a tool's operations share evidence
    speaks = {pair.key: key for key, pair in pairs.items()}
    per_op = {key: pair.operation_estimates() for key, pair in pairs.items()}
    op_defaults = _moderated(
        {tool: per_op[key] for tool, key in speaks.items()}, DEFAULT_OPERATION_SPREAD, weight
    )
    op_spread = {k: _at_least(op_defaults[p.key], weight, per_op[k]) for k, p in pairs.items()}
    seen = {key: pair.machines(machine, op_spread[key]) for key, pair in pairs.items()}
    found = {
        key: between_estimate(
            seen[key].others, pair.prior_mean, pair.prior_information, seen[key].reference
        )
        for key, pair in pairs.items()
    }
    defaults = _moderated(
        {tool: [found[key]] for tool, key in speaks.items()}, default_spread, weight
    )
    spreads = {key: _at_least(defaults[p.key], weight, [found[key]]) for key, p in pairs.items()}
    return {
        key: _Seen(
            spread,
            op_spread[key],
            seen[key],
            found[key][1],
            lower_bound(spread, weight + found[key][1]),
        )
        for key, spread in spreads.items()
    }


def _moderated(
    found: Mapping[_Key, Sequence[tuple[float, int]]], default: float, weight: float
) -> dict[_Key, _Default]:
    """Each key's default: ``default`` held as ``weight`` with the other keys' estimates.

    ``found``: per tool and quantity, its estimates ``(τ̂², dof)``. The default is what each
    one's own estimates are pooled with (:func:`supervisor.fleet.spread.pooled`); where the
    others had any degree of freedom it is also the floor, else the floor is 0.
    """
    out = {}
    for key in found:
        others = [est for k, ests in found.items() if k != key for est in ests]
        value = pooled(default, weight, others)
        out[key] = (value, value if sum(dof for _, dof in others) else 0.0)
    return out


def _prior(pair: _Pair, seen: _Seen, halted: bool = False) -> FleetPrior:
    """``pair``'s prior for a new operation on the plan's machine, ``seen`` its spreads.

    ``halted``: a plan of its tool halted after it learned. Its readings stay out of the
    fleet (issue 32), yet the halt says a machine's reading went past what the band allowed:
    the spread read from the plans left in is the lower for it, so the band's optimum is
    checked at :data:`FLEET_VETO_Z` sd, as where the spread itself passes the band. Measured
    (``closed_loop.py --fleet 4``, 200 scenarios): machines 20 % apart, first-part crossings
    63 -> 50 in 180 new machines, 0.569 -> 0.548 of the oracle at the first part, 0.911 ->
    0.914 after 3, 0.965 -> 0.971 after 30; 3 % apart, every figure the same.
    """
    belief, provenance = _fleet(pair, seen)
    mean, cov = belief.mean, belief.cov
    own = seen.machines.own
    if own is not None:  # this machine's offset, as its own readings show it
        fleet_information = np.linalg.inv(belief.cov)
        cov = np.linalg.inv(fleet_information + own.information)
        mean = cov @ (fleet_information @ belief.mean + own.vector)
    cov = cov.copy()
    cov[0, 0] += seen.operation_spread**2  # the new operation's own offset (hierarchy)
    prior = in_operation_terms(pair.catalogue, pair.op.context, mean, cov)
    why = tuple(r for r, on in (("spread", _beyond_band(pair, seen)), ("halted", halted)) if on)
    if why:
        prior = replace(prior, band_veto_z=FLEET_VETO_Z)
        provenance = replace(provenance, band_checked_why=why)
    return FleetPrior(prior, provenance)


def _beyond_band(pair: _Pair, seen: _Seen) -> bool:
    """Whether the fleet's machines, by their own readings, differ by more than the band.

    ``FLEET_VETO_Z`` times ``σ_b``'s lower credible bound past the band's ``dK/K`` (at 95 %,
    more than one new machine in 20 lies outside the band), where two machines or more
    measured it (one machine's spread is the default's, an assumption): the fleet's cone then
    vetoes the band's optimum at :data:`FLEET_VETO_Z` (``optimizer._agrees``).
    """
    return seen.machines_dof >= 1 and beyond_band(seen.spread_low, pair.band_rel)


def _fleet(pair: _Pair, seen: _Seen) -> tuple[FleetBelief, Provenance]:
    """A new machine's ``θ`` from the other machines' evidence, and where it came from."""
    belief = fleet_belief(
        seen.machines.others,
        pair.prior_mean,
        pair.prior_cov,
        seen.machines.reference,
        len(pair.catalogue.names),
        seen.spread,
    )
    provenance = Provenance(
        pair.catalogue.quantity,
        tuple(sorted({item.plan for item in pair.found})),
        tuple(sorted({item.machine for item in pair.found})),
        belief.spread,
        sum(item.posterior.observations for item in pair.found),
        seen.operation_spread,
    )
    return belief, provenance


def _at_least(default: _Default, weight: float, own: Sequence[tuple[float, int]]) -> float:
    """A tool's spread: the default pooled with its own estimates, never under the floor.

    A tool's own machines can show that they differ more than the plan's other tools' do,
    never less (hierarchy, "a plan's tools").
    """
    value, floor = default
    return max(floor, pooled(value, weight, own))
