r"""Making parts on a virtual machine: true values, noisy measurements, wear, violations.

:func:`run_part` answers a setpoint with the true values of every quantity of the registry
(:data:`models.quantities.QUANTITIES`), measurements of them (true value plus Gaussian noise of
the instrument's expanded uncertainty, Ivester & Heigel Table 5's "Measured" ± columns), tool
wear drift and every true limit crossed; :func:`measure_tool_wear` inverts the true tool-life
model (Eq. 8) for the flank wear an edge reached.

References
----------
.. [1] Ivester & Heigel, Smart Machining Systems (NIST): Eq. 8 and Table 5.
.. [2] JCGM 100:2008 (GUM), 6.2-6.3: an expanded uncertainty ``U = k·u`` with ``k = 2``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from models.errors import InputError
from supervisor.inputs.part_report import COVERAGE_FACTOR, Measurement, ToolWear
from supervisor.virtual.faults import PartFaults, reading, true_model_values
from supervisor.virtual.machine import (
    VIOLATION_RTOL,
    CompiledOperation,
    PartOutcome,
    Violation,
    VirtualMachine,
)


def run_part(
    machine: VirtualMachine,
    setpoints: Mapping[str, Mapping[str, float]],
    rng: np.random.Generator,
    edge_parts: Mapping[str, int] | None = None,
    faults: PartFaults | None = None,
) -> PartOutcome:
    r"""Make one part: true values, measurements and the true limits crossed.

    A measurement is the true value plus noise ``N(0, (U/2)^2)`` for the quantity's expanded
    uncertainty ``U`` (GUM 6.2-6.3, Table 5's ±2σ), reported with ``U`` and clipped at 0.
    With wear drift, force, roughness and spindle current are multiplied by

    .. math:: 1 + D \frac{n \cdot V}{V_\mathrm{edge}(x)}

    where ``D`` is ``wear_drift_per_edge_life``, ``n`` the parts the edge made before this
    one, ``V`` the operation's volume and ``V_edge`` the true tool life (Eq. 8) at the
    setpoint and the allowable flank wear; operations without a tool-life model do not drift.
    With ``faults`` the true models are bent and stepped before the drift, and the readings
    scaled in noise or dropped out (:mod:`supervisor.virtual.faults`); without them the
    noise stream and every value are as they were before the fault catalogue.

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
    faults : PartFaults, optional
        The faults in force for this part (:func:`supervisor.virtual.faults.part_faults`).

    Returns
    -------
    PartOutcome
        Measurements, true values and violations (true values compared with the operation's
        and the machine's limits, with a relative tolerance of :data:`VIOLATION_RTOL`).
    """
    compiled = machine.compiled
    _check_setpoints(compiled, setpoints)
    noise = rng.standard_normal(sum(len(c.measured) for c in compiled)).tolist()
    k = 0
    measurements: dict[str, dict[str, Measurement]] = {}
    true_values: dict[str, dict[str, float]] = {}
    violations: list[Violation] = []
    dropped: list[tuple[str, str]] = []
    for op in compiled:
        ln_x = _ln_setpoint(op, setpoints[op.name])
        used = (edge_parts or {}).get(op.name, 0)
        values = _true_values(op, ln_x, faults, machine.wear_drift_per_edge_life, used)
        measurements[op.name], lost = _readings(op, values, faults, noise, k)
        k += len(op.measured)
        dropped += [(op.name, quantity) for quantity in lost]
        violations += _crossed(op, values)
        true_values[op.name] = values
    return PartOutcome(measurements, true_values, tuple(violations), tuple(dropped))


def _check_setpoints(
    compiled: Sequence[CompiledOperation], setpoints: Mapping[str, Mapping[str, float]]
) -> None:
    """Refuse setpoints that are not one per operation of the machine."""
    if len(setpoints) != len(compiled) or any(c.name not in setpoints for c in compiled):
        expected = [c.name for c in compiled]
        raise InputError("setpoints", sorted(setpoints), f"need one per operation: {expected}")


def _true_values(
    op: CompiledOperation,
    ln_x: list[float],
    faults: PartFaults | None,
    drift: float,
    used: int,
) -> dict[str, float]:
    """The noise-free values of ``op`` at ``ln_x``: faulted, worn, with the derived ones."""
    values = {q: m.at(ln_x) for q, m in op.models}
    if faults is not None:
        values = true_model_values(faults, op, values, ln_x)
    if drift and used and "tool_life_mm3" in values:
        factor = 1.0 + drift * used * op.volume_mm3 / values["tool_life_mm3"]
        for quantity in op.drifting:
            values[quantity] *= factor
    for name, base, per in op.derived:  # the registry's derived quantities
        values[name] = per.at(ln_x) if base is None else values[base] * per.at(ln_x)
    return values


def _readings(
    op: CompiledOperation,
    values: Mapping[str, float],
    faults: PartFaults | None,
    noise: list[float],
    k: int,
) -> tuple[dict[str, Measurement], list[str]]:
    """The readings of ``op`` from ``noise[k:]``, and the quantities whose reading dropped out."""
    measured: dict[str, Measurement] = {}
    lost: list[str] = []
    for i, (quantity, u, sigma) in enumerate(op.measured, start=k):
        if faults is None:
            measured[quantity] = Measurement(max(values[quantity] + sigma * noise[i], 0.0), u)
        else:
            value, dropped = reading(faults, i, values[quantity], sigma, noise[i])
            measured[quantity] = Measurement(value, u)
            if dropped:
                lost.append(quantity)
    return measured, lost


def _crossed(op: CompiledOperation, values: Mapping[str, float]) -> list[Violation]:
    """The true limits of ``op`` that ``values`` cross, beyond :data:`VIOLATION_RTOL`."""
    violations = []
    for lim in op.limits:
        value = values[lim.value_of] / lim.scale
        if lim.sense == "max":
            crossed = value > lim.limit * (1.0 + VIOLATION_RTOL)
        else:
            crossed = value < lim.limit * (1.0 - VIOLATION_RTOL)
        if crossed:
            violations.append(Violation(op.name, lim.name, value, lim.limit))
    return violations


def _ln_setpoint(op: CompiledOperation, setpoint: Mapping[str, float]) -> list[float]:
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
    op = next((c for c in machine.compiled if c.name == operation), None)
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
