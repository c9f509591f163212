"""The robust optimisation of one operation as a log-linear program.

With ``x = ln`` of the cutting parameters every constrained quantity is a monomial, so each
robust constraint is one linear row ``a·x <= rhs`` (Ivester & Heigel Eqs. 10-13, "linearized
through a logarithmic transformation"; DESIGN.md, "The robust optimisation"):

- model maxima at the upper band edge: ``ln(K + ΔK_eff) + e·x <= ln(limit)`` (Eqs. 11-12),
- tool life at the lower band edge: ``ln(K − ΔK_eff) + e·x >= ln(parts_per_edge · volume)``
  (Eq. 13, written as the minimum it is; ``mr`` from Eq. 8 at the allowable flank wear),
- machine limits: spindle speed, feed rate, power ``F·v/60000`` and torque ``F·D/2000`` with
  the upper force band,
- objective: maximise ``ln(MRR)`` (Eq. 10).

``ΔK_eff = K · ΔY/Y`` carries the setpoint uncertainties too (GUM, :mod:`models.powerlaw`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from models import kinematics
from models.monomial import Monomial
from models.quantities import DERIVED_QUANTITIES, MODEL_QUANTITIES, Sense
from models.tool import Tool
from supervisor.errors import Conflict, InfeasibleError
from supervisor.plan import PARTS_PER_EDGE, Machine, Operation


@dataclass(frozen=True)
class Row:
    """One linear constraint ``coefficients · x <= rhs`` on ``x = ln(parameters)``.

    ``name`` is the quantity it limits, ``limit`` the limit in that quantity's unit and
    ``sense`` whether it is a maximum or a minimum. ``given_as`` names the limit as the
    engineer wrote it, which is ``limit / scale`` (``parts_per_edge`` is tool life / volume).
    """

    name: str
    coefficients: tuple[float, ...]
    rhs: float
    limit: float
    sense: Sense
    given_as: str
    scale: float = 1.0


@dataclass(frozen=True)
class LogLinearProgram:
    """Data of one operation's log-linear program (no solver objects)."""

    operation: str
    parameters: tuple[str, ...]
    objective: tuple[float, ...]
    rows: tuple[Row, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]


def formulate(operation: Operation, tool: Tool, machine: Machine) -> LogLinearProgram:
    """Build the robust log-linear program of ``operation`` with ``tool`` on ``machine``."""
    process = operation.process
    params = kinematics.PARAMETERS[process]
    context = operation.context
    rel = operation.setpoint_rel_uncertainty

    def row(
        name: str,
        monomial: Monomial,
        limit: float,
        sense: Sense = "max",
        scale: float = 1.0,
        given_as: str = "",
    ) -> Row:
        fixed = monomial.fix(context)
        coefficients = tuple(fixed.exponents.get(p, 0.0) for p in params)
        rhs = math.log(limit) - math.log(fixed.coefficient)
        if sense == "min":
            coefficients, rhs = tuple(-a for a in coefficients), -rhs
        return Row(name, coefficients, rhs, limit, sense, given_as or name, scale)

    def edge(quantity: str, sense: Sense) -> Monomial:
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
            rows.append(row(quantity, edge(quantity, "max"), limit))
        elif quantity == PARTS_PER_EDGE:
            volume = operation.volume_mm3
            lower_edge = edge("tool_life_mm3", "min")
            rows.append(
                row("tool_life_mm3", lower_edge, limit * volume, "min", volume, PARTS_PER_EDGE)
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
        elif quantity == "power_kW":
            monomial = edge("force_N", "max") * kinematics.power_per_newton_monomial()
        else:  # torque_Nm
            monomial = edge("force_N", "max") * kinematics.torque_per_newton_monomial(process)
        rows.append(row(quantity, monomial, limit, given_as=given_as))
    mrr = kinematics.mrr_monomial(process).fix(context)
    bounds = [operation.bounds[p] for p in params]
    return LogLinearProgram(
        operation=operation.name,
        parameters=params,
        objective=tuple(mrr.exponents.get(p, 0.0) for p in params),
        rows=tuple(rows),
        lower=tuple(math.log(lo) for lo, _ in bounds),
        upper=tuple(math.log(hi) for _, hi in bounds),
    )
