r"""A virtual machine: the true processes of a plan, compiled for fast parts, and its instruments.

Each operation of a plan gets a *true process*: its tool's models with a true coefficient and
true exponents,

.. math::

    Y_\mathrm{true}(x) = K (1 + \delta) \prod_i x_i^{e_i + \varepsilon_i},
    \qquad
    \left| Y_\mathrm{true}(x) - Y(x) \right| \le \frac{\Delta K}{K} Y(x)
    \quad \text{for every } x \text{ in the operation's bounds},

so the truth lies inside the band ``±ΔK`` of the nominal model ``Y = K Π x_i^e_i`` (Ivester &
Heigel Eqs. 5, 6, 8), as the paper's measurements did ("consistently within the ranges predicted
by their respective models", Table 5). The machine answers a setpoint with the true values,
measurements of them (true value plus Gaussian noise of the instrument's expanded uncertainty,
Table 5's "Measured" ± columns), optional tool-wear drift, and every true limit crossed
(:mod:`supervisor.virtual.simulate`); :mod:`supervisor.virtual.sampling` draws the truth.

References
----------
.. [1] Ivester & Heigel, Smart Machining Systems (NIST): Eqs. 5, 6 and 8 (the models), "Cutting
   Force Models" and "Surface Roughness Models" (ΔK is "the range of K that encompasses all of
   the points in the data set"), Table 5 (measured values with ±2σ uncertainties).
.. [2] JCGM 100:2008 (GUM), 6.2-6.3: an expanded uncertainty ``U = k·u`` with ``k = 2``.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, NamedTuple

from models import kinematics, quantities
from models.errors import InputError
from models.monomial import Monomial
from models.powerlaw import PowerLawModel
from models.quantities import DERIVED_QUANTITIES, Sense
from models.tool import Tool
from supervisor.inputs.part_report import COVERAGE_FACTOR, Measurement
from supervisor.inputs.plan import Operation, Plan

#: Force ± of Ivester & Heigel Table 5, "Measured" column, rows in order [N]; step 4 row AC1
#: (118 ± 80 N, ±68 % of its reading) is left out as an outlier.
TABLE5_MEASURED_FORCE_PM_N: tuple[float, ...] = (
    5, 12, 14, 15, 4, 8, 4, 3, 3, 3, 2, 3, 2, 2, 2, 2, 2, 2,
)  # fmt: skip
#: Finish (Ra) ± of Ivester & Heigel Table 5, "Measured" column, rows in order [µm].
TABLE5_MEASURED_FINISH_PM_UM: tuple[float, ...] = (
    0.04, 0.09, 0.08, 0.04, 0.02, 0.07, 0.02, 0.06, 0.06, 0.09,
    0.04, 0.03, 0.03, 0.05, 0.06, 0.05, 0.06, 0.07, 0.04,
)  # fmt: skip

#: Default expanded (≈2σ) measurement uncertainty per quantity, absolute, in its unit.
#:
#: - ``force_N``: 3 N, the median of :data:`TABLE5_MEASURED_FORCE_PM_N` (Ivester & Heigel
#:   Table 5; with the 80 N outlier the median is also 3 N).
#: - ``roughness_um``: 0.05 µm, the median of :data:`TABLE5_MEASURED_FINISH_PM_UM`.
#: - ``spindle_current_A``: 0.1 A, chosen (the paper measures no current): 0.5 % of a 20 A
#:   reading, the order of a Hall-effect current transducer's accuracy, and of the same
#:   relative size as the force figure on the paper's forces (0.2-1 % of 300-1500 N).
#: - ``flank_wear_mm``: 0.01 mm, chosen (the paper gives none for its microscope images
#:   calibrated against a length reference): about the repeatability of reading VB by eye.
DEFAULT_UNCERTAINTY: dict[str, float] = {
    "force_N": float(statistics.median(TABLE5_MEASURED_FORCE_PM_N)),
    "roughness_um": float(statistics.median(TABLE5_MEASURED_FINISH_PM_UM)),
    "spindle_current_A": 0.1,
    "flank_wear_mm": 0.01,
}

#: A true value may pass its limit by this fraction before it counts as a violation.
VIOLATION_RTOL = 1e-9


@dataclass(frozen=True)
class TrueProcess:
    """The true behaviour of one operation.

    Parameters
    ----------
    operation : str
        Name of the operation.
    tool : Tool
        The operation's tool with the *true* models (``dK = 0``), one per quantity of the
        nominal tool.
    """

    operation: str
    tool: Tool


@dataclass(frozen=True)
class Violation:
    """A true limit crossed by a part.

    Parameters
    ----------
    operation : str
        Name of the operation.
    quantity : str
        The limit's key: a quantity (``force_N``, ``power_kW`` ...) or ``parts_per_edge``.
    true_value : float
        The noise-free value, in the limit's unit (``parts_per_edge``: the true edge life in
        parts at the setpoint) [unit of the quantity].
    limit : float
        The limit crossed, the tighter of the operation's and the machine's for a machine
        quantity [unit of the quantity].
    """

    operation: str
    quantity: str
    true_value: float
    limit: float


@dataclass(frozen=True)
class PartOutcome:
    """What the virtual machine answers for one part.

    Parameters
    ----------
    measurements : Mapping[str, Mapping[str, Measurement]]
        Per operation, every measured quantity (the "max" model quantities: ``force_N``,
        ``roughness_um``, ``spindle_current_A``) with its expanded uncertainty.
    true_values : Mapping[str, Mapping[str, float]]
        Per operation, the noise-free value of every model quantity (with wear drift) and of
        ``power_kW``, ``torque_Nm``, ``spindle_rpm``, ``feed_rate_mm_min`` as
        :func:`models.tool.predict_all` names them.
    violations : tuple[Violation, ...]
        Every true limit crossed, in plan order.
    dropped : tuple[tuple[str, str], ...]
        ``(operation, quantity)`` of every reading that dropped out (the dropout fault of
        :mod:`supervisor.virtual.faults`); empty without it.
    """

    measurements: Mapping[str, Mapping[str, Measurement]]
    true_values: Mapping[str, Mapping[str, float]]
    violations: tuple[Violation, ...]
    dropped: tuple[tuple[str, str], ...] = ()

    def report(self, serial: str, setpoint_version: int) -> dict[str, Any]:
        """The part's report as the MES posts it (``POST /plans/{id}/parts``): its readings."""
        operations = [
            {
                "name": op,
                "measurements": {
                    q: {"value": m.value, "uncertainty": m.uncertainty} for q, m in ms.items()
                },
            }
            for op, ms in self.measurements.items()
        ]
        return {"serial": serial, "setpoint_version": setpoint_version, "operations": operations}


class Mono(NamedTuple):
    """A monomial with its context folded in, exponents aligned to the process parameters."""

    coefficient: float
    exponents: tuple[float, ...]

    def at(self, ln_x: list[float]) -> float:
        """Value at ``ln_x``, the logarithms of the cutting parameters in order."""
        return self.coefficient * math.exp(
            sum(e * v for e, v in zip(self.exponents, ln_x, strict=True))
        )


class LimitCheck(NamedTuple):
    """One limit a part's true values are compared with."""

    name: str  # the limit's key, as Violation.quantity
    value_of: str  # the true value it compares, a key of true_values
    scale: float  # true value / scale is in the limit's unit
    limit: float
    sense: Sense


class CompiledOperation(NamedTuple):
    """One operation, precomputed for :func:`supervisor.virtual.simulate.run_part`."""

    name: str
    parameters: tuple[str, ...]
    models: tuple[tuple[str, Mono], ...]
    measured: tuple[tuple[str, float, float], ...]  # quantity, expanded uncertainty, σ
    drifting: tuple[str, ...]
    volume_mm3: float
    derived: tuple[tuple[str, str | None, Mono], ...]  # quantity, based on, factor
    limits: tuple[LimitCheck, ...]
    wear: tuple[Mono, float] | None  # true tool life without VB, and its VB exponent


@dataclass(frozen=True)
class VirtualMachine:
    """A simulated machine making a plan's parts with true processes and noisy sensors.

    Parameters
    ----------
    plan : Plan
        The plan; its tools are the nominal models, its limits the ones a part must meet.
    processes : Mapping[str, TrueProcess]
        The true process of every operation, by operation name.
    uncertainty : Mapping[str, float]
        Expanded (≈2σ) measurement uncertainty of every measured quantity, absolute [unit of
        the quantity]; ``flank_wear_mm`` for :func:`supervisor.virtual.simulate.measure_tool_wear`.
    wear_drift_per_edge_life : float
        Relative rise of force, roughness and spindle current from a new edge to one at the end
        of its life [-]; 0 turns drift off.
    """

    plan: Plan
    processes: Mapping[str, TrueProcess]
    uncertainty: Mapping[str, float]
    wear_drift_per_edge_life: float = 0.0
    compiled: tuple[CompiledOperation, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        drift = self.wear_drift_per_edge_life
        if not (math.isfinite(drift) and drift >= 0):
            raise InputError("wear_drift_per_edge_life", drift, "must be a number >= 0")
        for quantity, u in self.uncertainty.items():
            if not (math.isfinite(u) and u >= 0):
                raise InputError(f"uncertainty.{quantity}", u, "must be a number >= 0")
        names = [op.name for op in self.plan.operations]
        unknown = sorted(set(self.processes) - set(names))
        if unknown:
            raise InputError("processes", unknown, "not operations of the plan")
        compiled = tuple(
            compile_operation(op, self._process(op), self) for op in self.plan.operations
        )
        object.__setattr__(self, "compiled", compiled)

    def _process(self, op: Operation) -> TrueProcess:
        process = self.processes.get(op.name)
        if process is None:
            raise InputError(f"processes.{op.name}", None, "no true process for the operation")
        nominal = self.plan.tools[op.tool]
        if set(process.tool.models) != set(nominal.models):
            raise InputError(
                f"processes.{op.name}.tool.models",
                sorted(process.tool.models),
                f"must model the quantities of {nominal.name}: {sorted(nominal.models)}",
            )
        if process.tool.process != op.process:
            where = f"processes.{op.name}.tool.process"
            raise InputError(where, process.tool.process, f"operation is {op.process}")
        return process


def compile_operation(
    op: Operation, process: TrueProcess, machine: VirtualMachine
) -> CompiledOperation:
    """``op`` with its true process folded into monomials of its cutting parameters."""
    params = kinematics.PARAMETERS[op.process]
    context = op.context

    def fold(monomial: Monomial, where: str) -> Mono:
        missing = sorted(set(monomial.exponents) - set(params) - set(context))
        if missing:
            raise InputError(where, missing, "inputs neither parameters nor context")
        fixed = monomial.fix(context)
        return Mono(fixed.coefficient, tuple(fixed.exponents.get(p, 0.0) for p in params))

    tool = process.tool
    models = tuple(
        (q, fold(m.monomial, f"processes.{op.name}.tool.models.{q}"))
        for q, m in tool.models.items()
    )
    measured = []
    for quantity, model in tool.models.items():
        if model.info.sense != "max":
            continue
        if quantity not in machine.uncertainty:
            raise InputError(f"uncertainty.{quantity}", None, "required: the quantity is measured")
        u = machine.uncertainty[quantity]
        measured.append((quantity, u, u / COVERAGE_FACTOR))
    where = f"operations.{op.name}"
    derived = []
    for entry in DERIVED_QUANTITIES.values():
        base = entry.based_on
        per = entry.factor_of(op.process)
        inputs = set(per.exponents) - set(params)
        if (base is None or base in tool.models) and inputs <= set(context):
            derived.append((entry.name, base, fold(per, where)))
    return CompiledOperation(
        name=op.name,
        parameters=params,
        models=models,
        measured=tuple(measured),
        drifting=tuple(q for q in tool.models if quantities.quantity(q).drifts_with_wear),
        volume_mm3=op.volume_mm3,
        derived=tuple(derived),
        limits=_limits(op, machine.plan),
        wear=_wear_model(op, tool.models.get("tool_life_mm3"), params),
    )


def _limits(op: Operation, plan: Plan) -> tuple[LimitCheck, ...]:
    """The operation's limits, and per machine quantity the tighter of machine and operation."""
    limits: list[LimitCheck] = []
    derived = dict(plan.machine.limits())
    for key, value in op.limits.items():
        quantity = quantities.limited_by(key)
        if quantity.kind == "derived":
            derived[quantity.name] = min(value, derived.get(quantity.name, math.inf))
            continue
        scale = op.volume_mm3 if quantity.limit_per_volume else 1.0
        limits.append(LimitCheck(key, quantity.name, scale, value, quantity.sense))
    limits += [LimitCheck(q, q, 1.0, v, DERIVED_QUANTITIES[q].sense) for q, v in derived.items()]
    return tuple(limits)


def _wear_model(
    op: Operation, life: PowerLawModel | None, params: tuple[str, ...]
) -> tuple[Mono, float] | None:
    """The true tool-life model with every input but VB folded in, and VB's exponent."""
    if life is None or life.exponents.get("flank_wear_mm", 0.0) <= 0:
        return None
    rest = {n: e for n, e in life.exponents.items() if n != "flank_wear_mm"}
    fixed = Monomial(life.K, rest).fix(op.context)
    exponents = tuple(fixed.exponents.get(p, 0.0) for p in params)
    return Mono(fixed.coefficient, exponents), life.exponents["flank_wear_mm"]
