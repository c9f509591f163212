"""A learned model in the fleet, and what its readings say about its tool (issue 32).

:class:`Learned` is what the database (or an imported document) holds of one operation's
learned model; :func:`readings_of` makes the evidence of each (:mod:`.evidence`), once for
all of a new plan's operations that share a tool.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from models.tool import Tool
from supervisor.fleet.evidence import LEAST_VARIANCE, Evidence, evidences, least_variance
from supervisor.inputs.plan import Operation
from supervisor.rcb import posterior as post
from supervisor.rcb.learning import as_started
from supervisor.rcb.noise import NoiseScale
from supervisor.rcb.posterior import Posterior


@dataclass(frozen=True)
class Learned:
    """One operation's learned model in the fleet: where it was learned and what it knows.

    ``tool``: the operation's catalogue tool (its prior is rebuilt from it, ``coverage_k``,
    ``exponent_sd`` and ``edge_sd`` of the plan's settings); ``start``: the prior the plan
    started from where not the catalogue's (a fleet prior: its evidence is the fleet's, not
    this plan's, and is taken out so that it is not counted twice); ``chain``: the operation's
    evidence on its measuring chain's noise (its monitor's, :mod:`.noise`), where known.
    """

    machine: str
    plan: str
    operation: Operation
    tool: Tool
    posterior: Posterior
    coverage_k: float
    exponent_sd: float
    edge_sd: float = post.DEFAULT_EDGE_SD
    start: Posterior | None = None
    chain: NoiseScale | None = None


def proper(belief: Posterior) -> bool:
    """Every parameter of ``belief`` uncertain enough for the information form to be made.

    ``exponent_sd = 0`` (or an exponent of 0, ``edge_sd = 0`` with an edge-life limit) makes a
    prior that knows a parameter exactly: its inverse does not exist, and no evidence can move
    that parameter. Nearly so (a ``dK`` of 1e-9 of K) is as bad: its inverse exists, but the
    evidence made with it is round-off (:data:`~supervisor.fleet.evidence.LEAST_VARIANCE`).
    """
    if not all(0.0 < belief.cov[i][i] < math.inf for i in range(len(belief.cov))):
        return False
    return least_variance(belief) >= LEAST_VARIANCE


def start_of(item: Learned, quantity: str) -> Posterior:
    """The prior ``item``'s plan started from: the catalogue's, or a fleet's as it stands.

    A start its readings rejected was widened (a fleet prior by :mod:`supervisor.rcb.
    prior_check`, any by a surprise: :mod:`supervisor.rcb.learning`): the plan's evidence is
    what it learned beyond the widened one.
    """
    start = item.start
    if start is None:
        model = item.tool.models[quantity]
        start = post.prior(model, item.operation, item.coverage_k, item.exponent_sd, item.edge_sd)
    return as_started(start, item.posterior)


def readings_of(learned: Sequence[Learned]) -> list[tuple[Learned, Evidence | None]]:
    """Each learned model's evidence (None: it or its start is not :func:`proper`), made once.

    A plan's operations that share a tool read the same models; the evidence of all of them
    is made in one stacked computation (:func:`~supervisor.fleet.evidence.evidences`).
    """
    starts = [start_of(item, item.posterior.quantity) for item in learned]
    usable = [
        i
        for i, (item, start) in enumerate(zip(learned, starts, strict=True))
        if (start.names, start.edge_max) == (item.posterior.names, item.posterior.edge_max)
        and proper(start)
        and proper(item.posterior)
    ]
    made = evidences(
        [(learned[i].posterior, starts[i], learned[i].operation.context) for i in usable]
    )
    out: list[tuple[Learned, Evidence | None]] = [(item, None) for item in learned]
    for i, seen in zip(usable, made, strict=True):
        out[i] = (learned[i], seen)
    return out
