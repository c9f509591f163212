r"""An operation's cone from every reading its machine took with the same tool (issue 32).

The fleet's hierarchical model (:mod:`supervisor.fleet.hierarchy`) holds that a tool cuts a
material by one law on a machine, up to the machine's offset ``δ_m`` in ``ln K``: the
operations of a tool on one machine share ``θ_m`` (the fleet sums their evidence per
machine). A plan whose quantity started from a fleet prior (:mod:`supervisor.fleet.prior`)
is under that model, and learns its machine's ``θ_m`` from every operation of the tool: the
cone of operation ``a`` is that of ``a``'s belief with the evidence of the plan's other
operations ``b`` of the same tool added, each ``b``'s posterior less the prior it started
from (:func:`~supervisor.rcb.tool_terms.evidence`), in the tool's terms ``θ`` (the product of
Gaussians, as :mod:`supervisor.fleet.prior` adds a machine's own evidence):

.. math:: P' = P_a + Σ_b J_b, \qquad μ' = P'^{-1}\big(P_a μ_a + Σ_b h_b\big)

mapped back to ``a``'s ``β`` (:func:`~supervisor.rcb.tool_terms.in_operation_terms`). The
two finishing operations of one insert then learn from six readings after three parts
instead of three (``benchmarks/closed_loop.py --fleet``, docs/benchmarks.md).

The model can be wrong on a machine: two operations of one insert in contexts the law does
not hold (a groove's chip against a contour's), or a truth that is not a power law over both
operations' boxes (``--fault curvature`` bends each operation's law its own way). Before two
operations pool, each one's readings are weighed against the other's, as a fleet prior's
check weighs a machine's (:mod:`supervisor.rcb.prior_check`): the Bayes factor of its start
alone against its start with the other's evidence, each the Gaussian linear model's evidence
(:func:`~supervisor.rcb.tool_terms.log_evidence`). When either favours its start alone by the
odds of :data:`APART_PROBABILITY`, the two are kept apart at this report; the factor is
weighed again at every report, over every reading so far.

Only the cones the optimiser holds the setpoints to are pooled. Each operation's posterior
stays what its own readings taught: the monitor and the prior's check judge a reading
against it, and the fleet, which sums a machine's operations, counts each reading once. A
quantity that started from the catalogue keeps its operations apart, as it always has: the
single-plan closed loop is measured so, its faults included (a truth that is not a power law
over the operations' boxes, ``--fault curvature``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from supervisor.inputs.plan import Operation
from supervisor.rcb.beliefs import Beliefs
from supervisor.rcb.posterior import Posterior
from supervisor.rcb.tool_terms import (
    Evidence,
    evidence,
    in_operation_terms,
    in_tool_terms,
    log_evidence,
)

#: The prior probability that two operations of a tool on one machine follow two laws (a
#: context the model does not hold, a truth that is not a power law over both boxes): the
#: odds ``(1 − ε)/ε = 19`` their readings must beat to be kept apart, as a fleet prior's
#: check asks of a machine's (:mod:`supervisor.rcb.prior_check`; Kass & Raftery 1995).
APART_PROBABILITY = 0.05
#: The prior an operation's belief of a quantity started from, as ``learn`` reads it.
PriorOf = Callable[[Beliefs, Operation, str], Posterior]


def pooled(state: Beliefs, prior_of: PriorOf) -> dict[tuple[str, str], Posterior]:
    """Per (operation, quantity) from a fleet prior with siblings that read, its pooled belief.

    ``prior_of(state, operation, quantity)``: the prior an operation's belief started from
    (:func:`supervisor.rcb.learning.prior_of`). The others keep their own belief, and so
    does an operation whose readings and a sibling's tell two laws apart (module docstring).
    """
    operations = {op.name: op for op in state.plan.operations}
    groups: dict[tuple[str, str], list[str]] = {}
    for name, quantity in state.posterior:
        groups.setdefault((operations[name].tool, quantity), []).append(name)
    out: dict[tuple[str, str], Posterior] = {}
    for (_, quantity), names in groups.items():
        if len(names) < 2 or not any((n, quantity) in state.priors for n in names):
            continue
        seen: dict[str, _Read] = {}
        for n in names:
            if state.posterior[(n, quantity)].observations > 0:
                made = _read(state, operations[n], quantity, prior_of)
                if made is not None:
                    seen[n] = made
        for name in names:
            if (name, quantity) not in state.priors:
                continue
            belief = state.posterior[(name, quantity)]
            mine = seen.get(name)
            others = tuple(
                read.evidence
                for n, read in seen.items()
                if n != name
                and read.evidence.names == belief.names
                and (mine is None or (_agree(mine, read) and _agree(read, mine)))
            )
            if others:
                out[(name, quantity)] = _with(belief, operations[name], others)
    return out


@dataclass(frozen=True)
class _Read:
    """An operation's readings of a quantity in the tool's terms, and its start's belief."""

    evidence: Evidence
    start_mean: np.ndarray
    start_precision: np.ndarray


def _agree(a: _Read, b: _Read) -> bool:
    """Whether ``a``'s readings leave ``b``'s as evidence of ``a``'s law (module docstring)."""
    if a.evidence.names != b.evidence.names:
        return False
    precision = a.start_precision + b.evidence.information
    mean = np.linalg.solve(precision, a.start_precision @ a.start_mean + b.evidence.vector)
    info, h = a.evidence.information, a.evidence.vector
    alone = log_evidence(a.start_mean, a.start_precision, info, h)
    together = log_evidence(mean, precision, info, h)
    if alone is None or together is None:
        return False
    return alone - together <= math.log((1 - APART_PROBABILITY) / APART_PROBABILITY)


def _read(state: Beliefs, operation: Operation, quantity: str, prior_of: PriorOf) -> _Read | None:
    """What ``operation``'s readings of ``quantity`` taught (kept on the immutable belief)."""
    belief = state.posterior[(operation.name, quantity)]
    start = prior_of(state, operation, quantity)
    kept: dict[str, tuple[Posterior, _Read | None]] = belief.__dict__.setdefault(
        "_pooling_read", {}
    )
    hit = kept.get("read")
    if hit is not None and hit[0] is start:
        return hit[1]
    made: _Read | None = None
    if start.names == belief.names and start.edge_max == belief.edge_max:
        mean, cov = in_tool_terms(start, operation.context)
        made = _Read(evidence(belief, start, operation.context), mean, np.linalg.inv(cov))
    kept["read"] = (start, made)
    return made


def _with(belief: Posterior, operation: Operation, others: Sequence[Evidence]) -> Posterior:
    """``belief`` with ``others``' evidence added in the tool's terms (module docstring)."""
    kept: dict[str, tuple[tuple[Evidence, ...], Posterior]] = belief.__dict__.setdefault(
        "_pooling_result", {}
    )
    hit = kept.get("result")
    if hit is not None and len(hit[0]) == len(others):
        if all(a is b for a, b in zip(hit[0], others, strict=True)):
            return hit[1]
    mean, cov = in_tool_terms(belief, operation.context)
    information = np.linalg.inv(cov)
    vector = information @ mean
    for seen in others:
        information = information + seen.information
        vector = vector + seen.vector
    pooled_cov = np.linalg.inv(information)
    pooled_cov = 0.5 * (pooled_cov + pooled_cov.T)
    made = in_operation_terms(belief, operation.context, pooled_cov @ vector, pooled_cov)
    kept["result"] = (tuple(others), made)
    return made
