"""A plan's start: the robust optimum under the catalogue or, for ``learn``, under other priors.

With priors (a fleet prior, issue 32: :mod:`supervisor.fleet.prior` makes them), ``learn``'s
posterior of each (operation, quantity) given starts at its prior, which also stands in for the
catalogue's wherever ``learn`` reads the prior back (:func:`supervisor.rcb.learning.rescaled`);
the first setpoints hold under their cones.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

from models.errors import InputError
from models.tool import Tool
from supervisor.inputs.plan import Plan
from supervisor.optimize.optimizer import optimize_plan
from supervisor.optimize.result import PlanResult
from supervisor.rcb.cone import Cone
from supervisor.rcb.posterior import Posterior
from supervisor.rcb.state import RcbSettings, RcbState, prior_sigma


def start(
    plan: Plan,
    settings: RcbSettings | None = None,
    priors: Mapping[tuple[str, str], Posterior] | None = None,
) -> RcbState:
    """The initial state: catalogue models, robust optimum as setpoint version 1.

    ``priors``: ``learn``'s prior per (operation, quantity) where it is not the catalogue's (a
    fleet prior, :mod:`supervisor.fleet.prior`); the first setpoints then hold under their cones.
    """
    settings = settings or RcbSettings()
    tools = {op.name: plan.tools[op.tool] for op in plan.operations}
    sigma = {
        (op, q): prior_sigma(m, settings)
        for op, tool in tools.items()
        for q, m in tool.models.items()
    }
    state = RcbState(plan, tools, optimize_plan(plan, tools), 1, settings, sigma)
    return from_priors(state, priors) if priors else state


def learned_cones(state: RcbState) -> dict[str, dict[str, Cone]]:
    """The constraints beyond the band that ``state``'s strategy hands the optimiser."""
    return state.settings.rule.cones(state)


def optimize_state(
    state: RcbState, tools: Mapping[str, Tool], posterior: Mapping[tuple[str, str], Posterior]
) -> PlanResult:
    """The setpoints of ``state``'s plan under ``tools`` (and the cones of ``posterior``)."""
    trial = replace(state, tools=tools, posterior=posterior)
    return optimize_plan(
        state.plan,
        tools,
        previous=(state.setpoints, state.tools, learned_cones(state)),
        cones=learned_cones(trial),
    )


def from_priors(state: RcbState, priors: Mapping[tuple[str, str], Posterior]) -> RcbState:
    """``state`` (a plan's start) with ``learn``'s beliefs at ``priors``, re-optimised.

    Raises
    ------
    InputError
        The strategy is not ``learn``, or a key is not an (operation, quantity) of the plan.
    """
    strategy = state.settings.strategy
    if strategy != "learn":
        raise InputError("prior", "fleet", f"only learn starts from a fleet prior, not {strategy}")
    unknown = sorted(set(priors) - set(state.sigma))
    if unknown:
        raise InputError("prior", unknown, "not (operation, quantity) pairs of the plan")
    started = replace(state, posterior=dict(priors), priors=dict(priors))
    cones = started.settings.rule.cones(started)
    return replace(started, setpoints=optimize_plan(state.plan, state.tools, cones=cones))
