"""The robust optimisation of one operation as a log-linear program.

With ``x = ln`` of the cutting parameters every constrained quantity is a monomial, so each
robust constraint is one linear row ``a·x <= rhs`` (Ivester & Heigel Eqs. 10-13, "linearized
through a logarithmic transformation"; DESIGN.md, "The robust optimisation"):

- model maxima at the upper band edge: ``ln(K + ΔK_eff) + e·x <= ln(limit)`` (Eqs. 11-12),
- tool life at the lower band edge: ``ln(K − ΔK_eff) + e·x >= ln(parts_per_edge · volume)``
  (Eq. 13, written as the minimum it is; ``mr`` from Eq. 8 at the allowable flank wear),
- derived quantities (:data:`models.quantities.QUANTITIES`), each the tighter of the machine's
  limit and the operation's: spindle speed, feed rate, power ``F·v/60000`` and torque
  ``F·D/2000`` with the upper force band (a derived quantity inherits the band of the model it
  scales); each limit key is looked up in the registry, an unknown one is an error,
- Borangiu's domain constraints (Eqs. 2-7) of a milling operation's ``[operations.domain]``,
- objective: maximise ``ln(MRR)`` (Eq. 10), or, for ``objective = "productivity"``, minimise
  Borangiu's cost ``J`` (a posynomial, :mod:`supervisor.optimize.productivity`) under the same rows.

``ΔK_eff = K · ΔY/Y`` carries the setpoint uncertainties too (GUM, :mod:`models.powerlaw`).
:func:`formulate_domain` poses Borangiu's own (w, n) problem of one pass the same way.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from models import borangiu_cost, kinematics, quantities
from models import borangiu_domain as domain
from models.errors import InputError
from models.monomial import Monomial
from models.quantities import Quantity, Sense
from models.tool import Tool
from supervisor.borangiu.problem import DomainProblem
from supervisor.errors import Conflict, InfeasibleError
from supervisor.inputs.plan import Machine, Operation
from supervisor.optimize.learned import LearnedCone
from supervisor.optimize.program import ConeTerm, LogLinearProgram, Row


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
    cones: Mapping[str, LearnedCone] | None = None,
) -> LogLinearProgram:
    """Build the robust log-linear program of ``operation`` with ``tool`` on ``machine``.

    ``cones``: per quantity, a learned model's cone (``learn`` strategy) that replaces the
    band row of that quantity (and of power and torque, for ``force_N``).
    """
    edges = _Edges.of(operation, tool, cones or {})
    rows, derived = _limit_rows(edges, machine)
    rows += _derived_rows(edges, derived)
    params, context = edges.params, edges.context
    if operation.domain is not None:
        for lim in domain.milling_limits(operation.domain):
            rows.append(
                _row(params, context, lim.name, lim.monomial, lim.limit, lim.sense, check=True)
            )
    cost = _cost(operation, tool)
    mrr = kinematics.mrr_monomial(operation.process).fix(context)
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


@dataclass(frozen=True)
class _Edges:
    """The models of one operation at their guarding band edges, and their rows.

    A quantity with a learned cone (``learn`` strategy) is its nominal model and a cone row at
    each edge age; any other is the tool's model scaled to the edge of its band, ``K ± ΔK_eff``
    (Ivester & Heigel Eqs. 11-13).
    """

    operation: Operation
    tool: Tool
    learned: Mapping[str, LearnedCone]
    params: tuple[str, ...]
    factors: Mapping[tuple[str, int], tuple[np.ndarray, np.ndarray]]

    @classmethod
    def of(cls, operation: Operation, tool: Tool, learned: Mapping[str, LearnedCone]) -> _Edges:
        """The edges of ``operation`` with ``tool``; each cone factored at each edge age."""
        params = kinematics.PARAMETERS[operation.process]
        rel = operation.setpoint_rel_uncertainty
        factors = {(q, n): c.factor(params, rel, n) for q, c in learned.items() for n in c.edges}
        return cls(operation, tool, learned, params, factors)

    @property
    def context(self) -> Mapping[str, float]:
        """The operation's fixed context (tool diameter, flutes ...)."""
        return self.operation.context

    def row(
        self,
        name: str,
        monomial: Monomial,
        limit: float,
        sense: Sense = "max",
        scale: float = 1.0,
        given_as: str = "",
        of: str = "",
        edge_age: int = 0,
    ) -> Row:
        """:func:`_row` in the operation's parameters; a cone row if ``of`` was learned."""
        cone = self.learned.get(of)
        term = None
        if cone is not None:
            G, h = self.factors[(of, edge_age)]
            term = ConeTerm(G, h, cone.z)
        params, context = self.params, self.context
        return _row(params, context, name, monomial, limit, sense, scale, given_as, cone=term)

    def ages(self, quantity: str) -> tuple[int, ...]:
        """Edge ages a learned quantity's rows hold at (:attr:`Posterior.edges`); else (0,)."""
        return self.learned[quantity].edges if quantity in self.learned else (0,)

    def edge(self, quantity: Quantity, sense: Sense, edge_age: int = 0) -> Monomial:
        """The model of ``quantity`` at the band edge that guards a limit of ``sense``."""
        if quantity.name in self.learned:  # the nominal: the cone row adds the spread
            return self.learned[quantity.name].nominal(edge_age)
        operation = self.operation
        rel = operation.setpoint_rel_uncertainty
        model = self.tool.models[quantity.name]
        rel_band = model.relative_band(rel)
        factor = 1.0 + rel_band if sense == "max" else 1.0 - rel_band
        if factor <= 0:
            key = quantity.limit_name
            conflict = Conflict(key, operation.limits[key], 0.0, sense)
            causes = ", ".join(f"setpoint_rel_uncertainty.{k}={v:g}" for k, v in rel.items())
            held = (
                f"{quantity.name} band {rel_band:.3g}·K >= K from dK={model.dK:g}"
                + (f" and {causes}" if causes else "")
                + f": no {quantity.label} is guaranteed",
            )
            raise InfeasibleError(operation.name, (conflict,), held)
        return model.monomial.scaled(factor)


def _limit_rows(edges: _Edges, machine: Machine) -> tuple[list[Row], dict[str, tuple[float, str]]]:
    """The rows of the operation's model limits, and the derived limits still to pose.

    A derived limit is the tighter of the machine's and the operation's own, named as it was
    given; the limits are read in the order given (an unknown key is an error there).
    """
    operation = edges.operation
    rows: list[Row] = []
    derived = {
        q: (v, f"machine.{quantities.quantity(q).machine_field}")
        for q, v in machine.limits().items()
    }
    for key, limit in operation.limits.items():
        quantity = quantities.limited_by(key)
        if quantity.kind == "derived":
            if limit < derived.get(quantity.name, (math.inf,))[0]:
                derived[quantity.name] = (limit, key)
            continue
        # a model quantity, at its guarding band edge; a maximum at every edge age, a minimum
        # (tool life) for the new edge
        scale = operation.volume_mm3 if quantity.limit_per_volume else 1.0
        name, sense = quantity.name, quantity.sense
        for age in edges.ages(name) if sense == "max" else (0,):
            monomial = edges.edge(quantity, sense, age)
            rows.append(edges.row(name, monomial, limit * scale, sense, scale, key, name, age))
    return rows, derived


def _derived_rows(edges: _Edges, derived: Mapping[str, tuple[float, str]]) -> list[Row]:
    """The rows of the derived limits: exact kinematics, or scaled from a model's edge."""
    process = edges.operation.process
    rows: list[Row] = []
    for name, (limit, given_as) in derived.items():
        quantity = quantities.quantity(name)
        base = quantity.based_on
        if base is None:  # exact kinematics
            monomial = quantity.monomial(process)
            rows.append(edges.row(name, monomial, limit, quantity.sense, 1.0, given_as))
            continue
        # from the guarding edge of the model it scales, at every edge age
        for age in edges.ages(base):
            base_edge = edges.edge(quantities.quantity(base), quantity.sense, age)
            monomial = quantity.monomial(process, base_edge)
            rows.append(edges.row(name, monomial, limit, quantity.sense, 1.0, given_as, base, age))
    return rows


def _cost(operation: Operation, tool: Tool) -> tuple[Monomial, ...]:
    """Borangiu's cost ``J`` of ``objective = "productivity"``, its terms in the context fixed."""
    if operation.productivity is None:
        return ()
    power = None
    cutting_power = quantities.quantity("power_kW")
    force = tool.models.get(cutting_power.based_on or "")
    if force is not None:
        power = cutting_power.monomial(operation.process, force.monomial)
    terms = borangiu_cost.milling_cost_terms(operation.productivity, power)
    return tuple(t.fix(operation.context) for t in terms)


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
