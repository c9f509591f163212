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

Only the cones the optimiser holds the setpoints to are pooled. Each operation's posterior
stays what its own readings taught: the monitor and the prior's check judge a reading
against it, and the fleet, which sums a machine's operations, counts each reading once. A
quantity that started from the catalogue keeps its operations apart, as it always has: the
single-plan closed loop is measured so, its faults included (a truth that is not a power law
over the operations' boxes, ``--fault curvature``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from supervisor.inputs.plan import Operation
from supervisor.rcb.beliefs import Beliefs
from supervisor.rcb.posterior import Posterior
from supervisor.rcb.tool_terms import Evidence, evidence, in_operation_terms, in_tool_terms

#: The prior an operation's belief of a quantity started from, as ``learn`` reads it.
PriorOf = Callable[[Beliefs, Operation, str], Posterior]


def pooled(state: Beliefs, prior_of: PriorOf) -> dict[tuple[str, str], Posterior]:
    """Per (operation, quantity) from a fleet prior with siblings that read, its pooled belief.

    ``prior_of(state, operation, quantity)``: the prior an operation's belief started from
    (:func:`supervisor.rcb.learning.prior_of`). The others keep their own belief.
    """
    operations = {op.name: op for op in state.plan.operations}
    groups: dict[tuple[str, str], list[str]] = {}
    for name, quantity in state.posterior:
        groups.setdefault((operations[name].tool, quantity), []).append(name)
    out: dict[tuple[str, str], Posterior] = {}
    for (_, quantity), names in groups.items():
        if len(names) < 2 or not any((n, quantity) in state.priors for n in names):
            continue
        seen = {
            n: _evidence(state, operations[n], quantity, prior_of)
            for n in names
            if state.posterior[(n, quantity)].observations > 0
        }
        for name in names:
            if (name, quantity) not in state.priors:
                continue
            belief = state.posterior[(name, quantity)]
            others = tuple(
                e
                for n, e in seen.items()
                if n != name and e is not None and e.names == belief.names
            )
            if others:
                out[(name, quantity)] = _with(belief, operations[name], others)
    return out


def _evidence(
    state: Beliefs, operation: Operation, quantity: str, prior_of: PriorOf
) -> Evidence | None:
    """What ``operation``'s readings of ``quantity`` taught (kept on the immutable belief)."""
    belief = state.posterior[(operation.name, quantity)]
    start = prior_of(state, operation, quantity)
    kept: dict[str, tuple[Posterior, Evidence | None]] = belief.__dict__.setdefault(
        "_pooling_evidence", {}
    )
    hit = kept.get("evidence")
    if hit is not None and hit[0] is start:
        return hit[1]
    made: Evidence | None = None
    if start.names == belief.names and start.edge_max == belief.edge_max:
        made = evidence(belief, start, operation.context)
    kept["evidence"] = (start, made)
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
