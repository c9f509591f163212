r"""A virtual machine: true processes inside the model bands, noisy measurements, tool wear.

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
Table 5's "Measured" ± columns), optional tool-wear drift, and every true limit crossed.

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
from typing import NamedTuple

import numpy as np

from models import kinematics, quantities
from models.errors import InputError
from models.monomial import Monomial
from models.powerlaw import PowerLawModel
from models.quantities import DERIVED_QUANTITIES, Sense
from models.tool import Tool
from supervisor.inputs.part_report import Measurement, ToolWear
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
#: Coverage factor of an expanded uncertainty: ``σ = U / 2`` (GUM 6.2-6.3; Table 5's ±2σ).
COVERAGE_FACTOR = 2.0
#: The truth is kept this far (relative, in ln) inside the band edge, against round-off.
_BAND_MARGIN = 1e-12


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
    """

    measurements: Mapping[str, Mapping[str, Measurement]]
    true_values: Mapping[str, Mapping[str, float]]
    violations: tuple[Violation, ...]


class _Mono(NamedTuple):
    """A monomial with its context folded in, exponents aligned to the process parameters."""

    coefficient: float
    exponents: tuple[float, ...]

    def at(self, ln_x: list[float]) -> float:
        return self.coefficient * math.exp(
            sum(e * v for e, v in zip(self.exponents, ln_x, strict=True))
        )


class _Limit(NamedTuple):
    name: str  # the limit's key, as Violation.quantity
    value_of: str  # the true value it compares, a key of true_values
    scale: float  # true value / scale is in the limit's unit
    limit: float
    sense: Sense


class _Compiled(NamedTuple):
    """One operation, precomputed for :func:`run_part`."""

    name: str
    parameters: tuple[str, ...]
    models: tuple[tuple[str, _Mono], ...]
    measured: tuple[tuple[str, float, float], ...]  # quantity, expanded uncertainty, σ
    drifting: tuple[str, ...]
    volume_mm3: float
    derived: tuple[tuple[str, str | None, _Mono], ...]  # quantity, based on, factor
    limits: tuple[_Limit, ...]
    wear: tuple[_Mono, float] | None  # true tool life without VB, and its VB exponent


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
        the quantity]; ``flank_wear_mm`` for :func:`measure_tool_wear`.
    wear_drift_per_edge_life : float
        Relative rise of force, roughness and spindle current from a new edge to one at the end
        of its life [-]; 0 turns drift off.
    """

    plan: Plan
    processes: Mapping[str, TrueProcess]
    uncertainty: Mapping[str, float]
    wear_drift_per_edge_life: float = 0.0
    _compiled: tuple[_Compiled, ...] = field(init=False, repr=False, compare=False)

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
        compiled = tuple(_compile(op, self._process(op), self) for op in self.plan.operations)
        object.__setattr__(self, "_compiled", compiled)

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


def _compile(op: Operation, process: TrueProcess, machine: VirtualMachine) -> _Compiled:
    params = kinematics.PARAMETERS[op.process]
    context = op.context

    def fold(monomial: Monomial, where: str) -> _Mono:
        missing = sorted(set(monomial.exponents) - set(params) - set(context))
        if missing:
            raise InputError(where, missing, "inputs neither parameters nor context")
        fixed = monomial.fix(context)
        return _Mono(fixed.coefficient, tuple(fixed.exponents.get(p, 0.0) for p in params))

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
    return _Compiled(
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


def _limits(op: Operation, plan: Plan) -> tuple[_Limit, ...]:
    """The operation's limits, and per machine quantity the tighter of machine and operation."""
    limits: list[_Limit] = []
    derived = dict(plan.machine.limits())
    for key, value in op.limits.items():
        quantity = quantities.limited_by(key)
        if quantity.kind == "derived":
            derived[quantity.name] = min(value, derived.get(quantity.name, math.inf))
            continue
        scale = op.volume_mm3 if quantity.limit_per_volume else 1.0
        limits.append(_Limit(key, quantity.name, scale, value, quantity.sense))
    limits += [_Limit(q, q, 1.0, v, DERIVED_QUANTITIES[q].sense) for q, v in derived.items()]
    return tuple(limits)


def _wear_model(
    op: Operation, life: PowerLawModel | None, params: tuple[str, ...]
) -> tuple[_Mono, float] | None:
    """The true tool-life model with every input but VB folded in, and VB's exponent."""
    if life is None or life.exponents.get("flank_wear_mm", 0.0) <= 0:
        return None
    rest = {n: e for n, e in life.exponents.items() if n != "flank_wear_mm"}
    fixed = Monomial(life.K, rest).fix(op.context)
    exponents = tuple(fixed.exponents.get(p, 0.0) for p in params)
    return _Mono(fixed.coefficient, exponents), life.exponents["flank_wear_mm"]


def sample_machine(
    plan: Plan,
    seed: int,
    *,
    spread: float = 1 / 3,
    exponent_spread: float = 0.05,
    uncertainty: Mapping[str, float] | None = None,
    wear_drift_per_edge_life: float = 0.0,
) -> VirtualMachine:
    r"""A virtual machine whose true processes are drawn inside the plan's model bands.

    For every operation (in plan order, each with its own sub-stream of
    ``numpy.random.default_rng(seed)``) and every model of its tool with ``dK > 0`` (in
    quantity-name order), the true model is

    .. math:: Y_\mathrm{true} = K (1 + \delta) \prod_i x_i^{e_i + \varepsilon_i},
              \quad \varepsilon_i \sim N(0, (s_e e_i)^2),
              \quad \delta \sim N(0, (s\,\Delta K / K)^2)
              \text{ truncated so that }
              1 - \frac{\Delta K}{K} \le (1 + \delta) \prod_i x_i^{\varepsilon_i}
              \le 1 + \frac{\Delta K}{K}

    at every corner of the operation's bounds box (context inputs such as ``flank_wear_mm`` at
    the operation's value). The ratio true/nominal is log-linear in ``ln x``, so its extremes
    over the box are at the corners and the truth stays inside the band everywhere in the box
    (outside the bounds, e.g. a catalogue setpoint beyond them, it may leave the band).
    Where even ``δ = 0`` leaves a corner outside, ``ε`` is shrunk toward 0 until it fits.
    Models with ``dK = 0`` stay exact.

    Parameters
    ----------
    plan : Plan
        The plan; nominal models are its tools.
    seed : int
        Seed of the draw; the same seed gives the same machine.
    spread : float
        Standard deviation of ``δ`` as a fraction of the band ``ΔK/K`` [-]. The default 1/3
        reads the band as 3σ: the paper's bands encompass all of a few dozen data points
        (Ivester & Heigel, "Cutting Force Models"), and the largest ``|z|`` of 30-100 normal
        draws is 2.3-2.7 on average, so a band is about 2.5-3 standard deviations of the
        process about the model. The truncation keeps every truth inside its band, as the
        paper's measurements were.
    exponent_spread : float
        Standard deviation of ``ε_i`` relative to ``|e_i|`` [-].
    uncertainty : Mapping[str, float], optional
        Expanded measurement uncertainties by quantity [unit of the quantity]; those not given
        come from :data:`DEFAULT_UNCERTAINTY`.
    wear_drift_per_edge_life : float
        Relative rise of force, roughness and spindle current over an edge's life [-], 0 for
        none (see :func:`run_part`). The catalogue band is read as covering the process over
        an edge's whole life (the paper's data were taken with edges at various wear): the
        new edge's truth of a drifting quantity is drawn so that the worn edge's, ``1 + D``
        times it, still lies under the band's upper edge.

    Returns
    -------
    VirtualMachine
        The machine, with :class:`TrueProcess` per operation.
    """
    for name, value in (("spread", spread), ("exponent_spread", exponent_spread)):
        if not (math.isfinite(value) and value >= 0):
            raise InputError(name, value, "must be a number >= 0")
    streams = np.random.default_rng(seed).spawn(len(plan.operations))
    processes: dict[str, TrueProcess] = {}
    for op, rng in zip(plan.operations, streams, strict=True):
        nominal = plan.tools[op.tool]
        wears = wear_drift_per_edge_life > 0 and "tool_life_mm3" in nominal.models
        true_models = {
            q: _true_model(
                nominal.models[q],
                op,
                rng,
                spread,
                exponent_spread,
                wear_drift_per_edge_life
                if wears and quantities.quantity(q).drifts_with_wear
                else 0.0,
            )
            for q in sorted(nominal.models)
        }
        tool = Tool(
            name=nominal.name,
            process=nominal.process,
            models={q: true_models[q] for q in nominal.models},
            description=f"true process of operation {op.name!r} (virtual machine, seed {seed})",
            material=nominal.material,
            source=f"sampled inside the bands of {nominal.source or nominal.name}",
        )
        processes[op.name] = TrueProcess(op.name, tool)
    return VirtualMachine(
        plan=plan,
        processes=processes,
        uncertainty={**DEFAULT_UNCERTAINTY, **(uncertainty or {})},
        wear_drift_per_edge_life=wear_drift_per_edge_life,
    )


def _true_model(
    model: PowerLawModel,
    op: Operation,
    rng: np.random.Generator,
    spread: float,
    exponent_spread: float,
    drift: float = 0.0,
) -> PowerLawModel:
    """One true model inside ``model``'s band over ``op``'s bounds (see :func:`sample_machine`).

    ``drift``: the rise over an edge's life the model will see; the new edge's truth is drawn
    that much under the band's upper edge, so the worn edge's stays inside it too.
    """
    source = f"true model of {op.name!r}, sampled inside the band of K = {model.K:g} ± {model.dK:g}"
    if model.dK == 0:
        return PowerLawModel(model.quantity, model.K, 0.0, dict(model.exponents), source)
    names = sorted(model.exponents)
    band = model.dK / model.K
    scales = np.array([exponent_spread * abs(model.exponents[n]) for n in names])
    eps = rng.standard_normal(len(names)) * scales
    u = float(rng.random())
    low, high = _log_range(names, op)
    # ln(true/nominal) = ln(1 + δ) + Σ ε_i ln x_i must lie in [ln(1 − b), ln(1 + b)]
    ln_lo = math.log1p(-band) + _BAND_MARGIN if band < 1 else -math.inf
    # a drift beyond the band's width cannot fit inside it: the truth at the band's low edge
    ln_hi = max(math.log1p(band) - math.log1p(drift) - _BAND_MARGIN, min(ln_lo, 0.0))
    s_hi = float(np.maximum(eps * low, eps * high).sum())
    s_lo = float(np.minimum(eps * low, eps * high).sum())
    shrink = 1.0
    if s_hi > ln_hi:
        shrink = min(shrink, max(ln_hi, 0.0) / s_hi)
    if s_lo < ln_lo:
        shrink = min(shrink, ln_lo / s_lo)
    eps, s_hi, s_lo = eps * shrink, s_hi * shrink, s_lo * shrink
    # a band wider than K (b >= 1) would allow a truth down to 0: keep K_true > 0
    delta_lo = max(math.expm1(ln_lo - s_lo), -1.0 + 1e-6)
    delta_hi = math.expm1(ln_hi - s_hi)
    delta = _truncated_normal(spread * band, delta_lo, delta_hi, u)
    exponents = {n: model.exponents[n] + float(e) for n, e in zip(names, eps, strict=True)}
    return PowerLawModel(
        model.quantity, model.K * (1.0 + delta), 0.0, exponents, source, model.reference
    )


def _log_range(names: list[str], op: Operation) -> tuple[np.ndarray, np.ndarray]:
    """``ln`` of the low and high end of each variable: bounds, or the context value twice."""
    low, high = [], []
    for name in names:
        if name in op.bounds:
            lo, hi = op.bounds[name]
        elif name in op.context:
            lo = hi = op.context[name]
        else:
            raise InputError(f"operations.{op.name}", name, "model input neither bound nor context")
        low.append(math.log(lo))
        high.append(math.log(hi))
    return np.array(low), np.array(high)


def _truncated_normal(sigma: float, low: float, high: float, u: float) -> float:
    """``N(0, σ²)`` truncated to ``[low, high]`` (which holds 0), by inverting its CDF at ``u``."""
    if sigma == 0 or low >= high:
        return min(max(0.0, low), high)
    normal = statistics.NormalDist(0.0, sigma)
    p_lo, p_hi = normal.cdf(low), normal.cdf(high)
    p = min(max(p_lo + u * (p_hi - p_lo), 1e-300), 1.0 - 1e-16)
    return min(max(normal.inv_cdf(p), low), high)


def oracle_tools(machine: VirtualMachine) -> dict[str, Tool]:
    """The true tool of every operation (``dK = 0``), for ``optimize_plan(plan, tools=...)``.

    The optimum with these tools is the fastest any controller could run without crossing a
    true limit (with no setpoint uncertainty in the plan): the oracle.
    """
    return {name: process.tool for name, process in machine.processes.items()}


def run_part(
    machine: VirtualMachine,
    setpoints: Mapping[str, Mapping[str, float]],
    rng: np.random.Generator,
    edge_parts: Mapping[str, int] | None = None,
) -> PartOutcome:
    r"""Make one part: true values, measurements and the true limits crossed.

    A measurement is the true value plus noise ``N(0, (U/2)^2)`` for the quantity's expanded
    uncertainty ``U`` (GUM 6.2-6.3, Table 5's ±2σ), reported with ``U`` and clipped at 0.
    With wear drift, force, roughness and spindle current are multiplied by

    .. math:: 1 + D \frac{n \cdot V}{V_\mathrm{edge}(x)}

    where ``D`` is ``wear_drift_per_edge_life``, ``n`` the parts the edge made before this
    one, ``V`` the operation's volume and ``V_edge`` the true tool life (Eq. 8) at the
    setpoint and the allowable flank wear; operations without a tool-life model do not drift.

    Parameters
    ----------
    machine : VirtualMachine
        The machine.
    setpoints : Mapping[str, Mapping[str, float]]
        For every operation of the plan, its cutting parameters (``depth_mm``, ``feed_mm_rev``,
        ``speed_m_min`` for turning) [units as named].
    rng : numpy.random.Generator
        Source of the measurement noise; the same state gives the same measurements.
    edge_parts : Mapping[str, int], optional
        Per operation, the parts made with its current edge before this one (0 if absent).

    Returns
    -------
    PartOutcome
        Measurements, true values and violations (true values compared with the operation's
        and the machine's limits, with a relative tolerance of :data:`VIOLATION_RTOL`).
    """
    compiled = machine._compiled
    if len(setpoints) != len(compiled) or any(c.name not in setpoints for c in compiled):
        expected = [c.name for c in compiled]
        raise InputError("setpoints", sorted(setpoints), f"need one per operation: {expected}")
    drift = machine.wear_drift_per_edge_life
    used_parts = edge_parts or {}
    noise = rng.standard_normal(sum(len(c.measured) for c in compiled)).tolist()
    k = 0
    measurements: dict[str, dict[str, Measurement]] = {}
    true_values: dict[str, dict[str, float]] = {}
    violations: list[Violation] = []
    for op in compiled:
        ln_x = _ln_setpoint(op, setpoints[op.name])
        values = {q: m.at(ln_x) for q, m in op.models}
        used = used_parts.get(op.name, 0)
        if drift and used and "tool_life_mm3" in values:
            factor = 1.0 + drift * used * op.volume_mm3 / values["tool_life_mm3"]
            for quantity in op.drifting:
                values[quantity] *= factor
        for name, base, per in op.derived:  # the registry's derived quantities
            values[name] = per.at(ln_x) if base is None else values[base] * per.at(ln_x)
        measured: dict[str, Measurement] = {}
        for quantity, u, sigma in op.measured:
            measured[quantity] = Measurement(max(values[quantity] + sigma * noise[k], 0.0), u)
            k += 1
        for lim in op.limits:
            value = values[lim.value_of] / lim.scale
            if lim.sense == "max":
                crossed = value > lim.limit * (1.0 + VIOLATION_RTOL)
            else:
                crossed = value < lim.limit * (1.0 - VIOLATION_RTOL)
            if crossed:
                violations.append(Violation(op.name, lim.name, value, lim.limit))
        measurements[op.name] = measured
        true_values[op.name] = values
    return PartOutcome(measurements, true_values, tuple(violations))


def _ln_setpoint(op: _Compiled, setpoint: Mapping[str, float]) -> list[float]:
    """``ln`` of the cutting parameters of ``op``; refuses missing, unknown or bad values."""
    if len(setpoint) != len(op.parameters):
        unknown = sorted(set(setpoint) - set(op.parameters))
        if unknown:
            raise InputError(f"setpoints.{op.name}", unknown, f"not parameters: {op.parameters}")
    ln_x = []
    for name in op.parameters:
        x = setpoint.get(name)
        if x is None or not (0.0 < x < math.inf):
            raise InputError(f"setpoints.{op.name}.{name}", x, "must be a positive finite number")
        ln_x.append(math.log(x))
    return ln_x


def measure_tool_wear(
    machine: VirtualMachine,
    operation: str,
    setpoint: Mapping[str, float],
    volume_mm3: float,
    rng: np.random.Generator,
) -> ToolWear:
    r"""Measure the flank wear of an edge after it removed ``volume_mm3`` at ``setpoint``.

    The true tool-life model (Ivester & Heigel Eq. 8), ``V = K d^a f^b v^c w^g``, inverted for
    the average flank wear ``w`` reached after removing ``V``:

    .. math:: w = \left( \frac{V}{K d^a f^b v^c} \right)^{1/g}

    plus noise ``N(0, (U/2)^2)`` with ``U = uncertainty["flank_wear_mm"]``, clipped at 0.

    Parameters
    ----------
    machine : VirtualMachine
        The machine.
    operation : str
        Name of an operation whose tool has a tool-life model with a flank-wear exponent.
    setpoint : Mapping[str, float]
        The cutting parameters the edge ran at [units as named].
    volume_mm3 : float
        Volume the edge removed since it was new [mm³].
    rng : numpy.random.Generator
        Source of the measurement noise.

    Returns
    -------
    ToolWear
        The measured flank wear [mm] and ``volume_mm3``.
    """
    op = next((c for c in machine._compiled if c.name == operation), None)
    if op is None:
        raise InputError("operation", operation, "not an operation of the plan")
    if op.wear is None:
        raise InputError("operation", operation, "its tool has no tool-life model in VB")
    if not (math.isfinite(volume_mm3) and volume_mm3 >= 0):
        raise InputError("volume_mm3", volume_mm3, "must be a number >= 0")
    if "flank_wear_mm" not in machine.uncertainty:
        raise InputError("uncertainty.flank_wear_mm", None, "required to measure tool wear")
    life, exponent = op.wear
    true_vb = (volume_mm3 / life.at(_ln_setpoint(op, setpoint))) ** (1.0 / exponent)
    u = machine.uncertainty["flank_wear_mm"]
    value = max(true_vb + u / COVERAGE_FACTOR * float(rng.standard_normal()), 0.0)
    return ToolWear(Measurement(value, u), volume_mm3)
