"""The robust optimisation of one operation as a log-linear program.

With ``x = ln`` of the cutting parameters every constrained quantity is a monomial, so each
robust constraint is one linear row ``a·x <= rhs`` (Ivester & Heigel Eqs. 10-13, "linearized
through a logarithmic transformation"; DESIGN.md, "The robust optimisation"):

- model maxima at the upper band edge: ``ln(K + ΔK_eff) + e·x <= ln(limit)`` (Eqs. 11-12),
- tool life at the lower band edge: ``ln(K − ΔK_eff) + e·x >= ln(parts_per_edge · volume)``
  (Eq. 13, written as the minimum it is; ``mr`` from Eq. 8 at the allowable flank wear),
- machine limits: spindle speed, feed rate, power ``F·v/60000`` and torque ``F·D/2000`` with
  the upper force band,
- Borangiu's domain constraints (Eqs. 2-7) of a milling operation's ``[operations.domain]``,
- objective: maximise ``ln(MRR)`` (Eq. 10), or, for ``objective = "productivity"``, minimise
  Borangiu's cost ``J`` (a posynomial, :mod:`supervisor.borangiu.productivity`) under the same rows.

``ΔK_eff = K · ΔY/Y`` carries the setpoint uncertainties too (GUM, :mod:`models.powerlaw`).
:func:`formulate_domain` poses Borangiu's own (w, n) problem of one pass the same way.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from models import borangiu_cost, kinematics
from models.errors import InputError
from models.monomial import Monomial
from models.quantities import DERIVED_QUANTITIES, MODEL_QUANTITIES, Sense
from models.tool import Tool
from supervisor.borangiu import domain
from supervisor.borangiu.problem import DomainProblem
from supervisor.errors import Conflict, InfeasibleError
from supervisor.inputs.plan import PARTS_PER_EDGE, Machine, Objective, Operation
from supervisor.rcb.posterior import Cone


@dataclass(frozen=True, eq=False)
class ConeTerm:
    """``z ‖G x + h‖``, the spread a learned row adds to its linear part (:mod:`.posterior`).

    ``G`` and ``h`` are arrays (not to be written to); a term is equal only to itself.
    """

    G: np.ndarray
    h: np.ndarray
    z: float


@dataclass(frozen=True)
class Row:
    """One linear constraint ``coefficients · x <= rhs`` on ``x = ln(parameters)``.

    ``name`` is the quantity it limits, ``limit`` the limit in that quantity's unit and
    ``sense`` whether it is a maximum or a minimum. ``given_as`` names the limit as the
    engineer wrote it, which is ``limit / scale`` (``parts_per_edge`` is tool life / volume).
    ``check`` is the bounded quantity of a row that no model predicts (Borangiu's domain), for
    the re-check of an optimum. ``cone``: a learned row is ``coefficients · x + z ‖G x + h‖
    <= rhs``, a second-order cone (:mod:`supervisor.rcb.posterior`).
    """

    name: str
    coefficients: tuple[float, ...]
    rhs: float
    limit: float
    sense: Sense
    given_as: str
    scale: float = 1.0
    check: Monomial | None = None
    cone: ConeTerm | None = None


@dataclass(frozen=True)
class LogLinearProgram:
    """Data of one operation's log-linear program (no solver objects).

    ``objective`` is the ``ln(MRR)`` gradient; ``cost`` the terms of ``J`` in ``parameters``
    (empty without cost data) and ``goal`` which of the two the optimum is for. ``start``: a
    point near the optimum (the last one), where cone rows get their first cuts.
    """

    operation: str
    parameters: tuple[str, ...]
    objective: tuple[float, ...]
    rows: tuple[Row, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    cost: tuple[Monomial, ...] = ()
    goal: Objective = "mrr"
    start: tuple[float, ...] | None = None


def _row(
    params: tuple[str, ...],
    context: Mapping[str, float],
    name: str,
    monomial: Monomial,
    limit: float,
    sense: Sense = "max",
    scale: float = 1.0,
    given_as: str = "",
    check: bool = False,
    cone: ConeTerm | None = None,
) -> Row:
    """``monomial <= limit`` (or ``>=``) as a row in ``ln(params)``, ``context`` fixed.

    With ``cone`` the monomial is the nominal of a learned model and the row a cone.
    """
    fixed = monomial.fix(context)
    coefficients = tuple(fixed.exponents.get(p, 0.0) for p in params)
    rhs = math.log(limit) - math.log(fixed.coefficient)
    if sense == "min":
        coefficients, rhs = tuple(-a for a in coefficients), -rhs
    return Row(
        name,
        coefficients,
        rhs,
        limit,
        sense,
        given_as or name,
        scale,
        monomial if check else None,
        cone,
    )


def formulate(
    operation: Operation,
    tool: Tool,
    machine: Machine,
    cones: Mapping[str, Cone] | None = None,
) -> LogLinearProgram:
    """Build the robust log-linear program of ``operation`` with ``tool`` on ``machine``.

    ``cones``: per quantity, a learned model's cone (``learn`` strategy) that replaces the
    band row of that quantity (and of power and torque, for ``force_N``).
    """
    learned = cones or {}
    process = operation.process
    params = kinematics.PARAMETERS[process]
    context = operation.context
    rel = operation.setpoint_rel_uncertainty
    factors = {
        (q, n): c.factor(params, rel, n) for q, c in learned.items() for n in c.posterior.edges
    }

    def row(
        name: str,
        monomial: Monomial,
        limit: float,
        sense: Sense = "max",
        scale: float = 1.0,
        given_as: str = "",
        of: str = "",
        edge_age: int = 0,
    ) -> Row:
        cone = learned.get(of)
        term = None
        if cone is not None:
            G, h = factors[(of, edge_age)]
            term = ConeTerm(G, h, cone.z)
        return _row(params, context, name, monomial, limit, sense, scale, given_as, cone=term)

    def ages(quantity: str) -> tuple[int, ...]:
        """Edge ages a learned quantity's rows hold at (:attr:`Posterior.edges`); else (0,)."""
        return learned[quantity].posterior.edges if quantity in learned else (0,)

    def edge(quantity: str, sense: Sense, edge_age: int = 0) -> Monomial:
        if quantity in learned:  # the nominal: the cone row adds the spread
            return learned[quantity].posterior.model(edge_parts=edge_age).monomial
        model = tool.models[quantity]
        rel_band = model.relative_band(rel)
        factor = 1.0 + rel_band if sense == "max" else 1.0 - rel_band
        if factor <= 0:
            conflict = Conflict(PARTS_PER_EDGE, operation.limits[PARTS_PER_EDGE], 0.0, sense)
            causes = ", ".join(f"setpoint_rel_uncertainty.{k}={v:g}" for k, v in rel.items())
            held = (
                f"{quantity} band {rel_band:.3g}·K >= K from dK={model.dK:g}"
                + (f" and {causes}" if causes else "")
                + ": no tool life is guaranteed",
            )
            raise InfeasibleError(operation.name, (conflict,), held)
        return model.monomial.scaled(factor)

    rows: list[Row] = []
    for quantity, limit in operation.limits.items():
        if quantity in MODEL_QUANTITIES:
            for age in ages(quantity):
                rows.append(
                    row(quantity, edge(quantity, "max", age), limit, of=quantity, edge_age=age)
                )
        elif quantity == PARTS_PER_EDGE:
            volume = operation.volume_mm3
            lower_edge = edge("tool_life_mm3", "min")
            rows.append(
                row(
                    "tool_life_mm3",
                    lower_edge,
                    limit * volume,
                    "min",
                    volume,
                    PARTS_PER_EDGE,
                    of="tool_life_mm3",
                )
            )
    # the tighter of the machine's limit and the operation's own, named as it was given
    machine_limits = {q: (v, f"machine.max_{q}") for q, v in machine.limits().items()}
    for quantity, limit in operation.limits.items():
        if quantity in DERIVED_QUANTITIES and limit < machine_limits.get(quantity, (math.inf,))[0]:
            machine_limits[quantity] = (limit, quantity)
    for quantity, (limit, given_as) in machine_limits.items():
        if quantity == "spindle_rpm":
            monomial = kinematics.spindle_rpm_monomial(process)
        elif quantity == "feed_rate_mm_min":
            monomial = kinematics.feed_rate_monomial(process)
        else:  # power_kW, torque_Nm: from the upper force edge, at every edge age
            per_newton = (
                kinematics.power_per_newton_monomial()
                if quantity == "power_kW"
                else kinematics.torque_per_newton_monomial(process)
            )
            for age in ages("force_N"):
                monomial = edge("force_N", "max", age) * per_newton
                rows.append(
                    row(quantity, monomial, limit, given_as=given_as, of="force_N", edge_age=age)
                )
            continue
        rows.append(row(quantity, monomial, limit, given_as=given_as))
    if operation.domain is not None:
        for lim in domain.milling_limits(operation.domain):
            rows.append(
                _row(params, context, lim.name, lim.monomial, lim.limit, lim.sense, check=True)
            )
    cost: tuple[Monomial, ...] = ()
    if operation.productivity is not None:
        power = None
        if "force_N" in tool.models:
            power = tool.models["force_N"].monomial * kinematics.power_per_newton_monomial()
        terms = borangiu_cost.milling_cost_terms(operation.productivity, power)
        cost = tuple(t.fix(context) for t in terms)
    mrr = kinematics.mrr_monomial(process).fix(context)
    bounds = [operation.bounds[p] for p in params]
    return LogLinearProgram(
        operation=operation.name,
        parameters=params,
        objective=tuple(mrr.exponents.get(p, 0.0) for p in params),
        rows=tuple(rows),
        lower=tuple(math.log(lo) for lo, _ in bounds),
        upper=tuple(math.log(hi) for _, hi in bounds),
        cost=cost,
        goal=operation.objective,
    )


def formulate_domain(problem: DomainProblem) -> LogLinearProgram:
    """Borangiu's (w, n) problem of one pass in ``x = ln(feed_rate_mm_min, spindle_rpm)``.

    Every constraint (2)-(7) is a row (with its check); the bounds are Eqs. 5-6 again, so that
    the program is bounded. The objective is ``ln w`` (the MRR at fixed depth and width); the
    cost is ``J(w, n)``.
    """
    params = (borangiu_cost.FEED_RATE, borangiu_cost.SPINDLE)
    rows = tuple(
        _row(params, {}, lim.name, lim.monomial, lim.limit, lim.sense, check=True)
        for lim in domain.wn_limits(problem.domain)
    )
    lower: list[float] = []
    upper: list[float] = []
    for name in ("feed_rate_mm_min", "spindle_rpm"):
        for side, ends in (("min", lower), ("max", upper)):
            value = getattr(problem.domain, f"{side}_{name}")
            if value is None:
                raise InputError(f"domain.{side}_{name}", None, "required: Eqs. 5-6 bound (w, n)")
            ends.append(math.log(value))
    return LogLinearProgram(
        operation=problem.name,
        parameters=params,
        objective=(1.0, 0.0),
        rows=rows,
        lower=tuple(lower),
        upper=tuple(upper),
        cost=borangiu_cost.wn_terms(problem.coefficients),
        goal="mrr",
    )
