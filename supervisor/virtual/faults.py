r"""What the faults of :mod:`supervisor.virtual.fault_spec` do to a part on a virtual machine.

:func:`supervisor.virtual.simulate.run_part` takes a :class:`PartFaults`, the faults in force
for one part, built by :func:`part_faults`:

- *curvature* ``C``: per model, ``ln y_true = ln y_powerlaw + C·b(x)`` with a smooth random
  bend ``b`` (:class:`Bend`), ``max |b| = 1`` over the operation's bounds box;
- *step* ``PART:FACTOR``: from part ``PART`` on every true maximum model quantity (force,
  roughness, spindle current; so power and torque, which follow force) is × FACTOR; tool
  life is not stepped (the closed loop does not measure it);
- *noise-scale* ``S``: the measurement noise is ``N(0, (S·U/2)²)`` for a reported ``U``;
- *noise-step* ``PART:S``: from part ``PART`` on the noise is ``S`` times that (a measuring
  chain that degrades late in a plan's life: a worn stylus, a loose dynamometer mount);
- *dropout* ``P``: a reading, with probability ``P``, is ``F·y_true`` with ``F ~ U(0.05, 0.30)``
  (a loose cable, an air cut, a broken insert), reported with the usual ``U``.

Wear is the machine's own drift (``wear_drift_per_edge_life``). A fault that draws has its own
stream, ``numpy.random.default_rng([seed, 1 + i])`` with ``i`` its index in
:data:`~supervisor.virtual.fault_spec.KINDS` (:func:`fault_rng`), so the measurement noise
stream ``default_rng(seed)`` and every fault-free result are as without the catalogue.

References
----------
.. [1] JCGM 100:2008 (GUM), 6.2-6.3: an expanded uncertainty ``U = k·u`` with ``k = 2``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from supervisor.virtual.fault_spec import KINDS, Faults
from supervisor.virtual.machine import CompiledOperation, VirtualMachine

#: A dropped-out reading is this range of fractions of its true value [-].
DROPOUT_FRACTION = (0.05, 0.30)


class Bend(NamedTuple):
    r"""A smooth bend of ``ln y`` over an operation's bounds box: a random quadratic ridge.

    With ``z_i = (ln x_i − c_i)/h_i`` the log-coordinates normalised to ``[−1, 1]`` over the
    box (``c``, ``h``: the midpoint and half-width of ``ln`` of the bounds) and a random
    direction ``w`` normalised so that ``Σ|w_i| = 1``,

    .. math:: t = \sum_i w_i z_i \in [-1, 1], \qquad
              C\,b(x) = \frac{C}{M} \left( a t + q t^2 \right), \qquad
              M = \max_{t \in [-1, 1]} |a t + q t^2|

    ``t`` takes every value of ``[−1, 1]`` over the box (``±1`` at the corners ``z = ±sign w``),
    so ``max |b| = 1`` over the box exactly; ``M`` is the largest of ``|a ± q|`` and, when the
    vertex ``t* = −a/(2q)`` lies inside, ``a²/(4|q|)``. The quadratic term is what makes the
    truth leave the power laws (a linear ``t`` only tilts the exponents).

    Parameters
    ----------
    center : tuple[float, ...]
        ``c_i``, midpoint of ``ln`` of each parameter's bounds [ln of the parameter's unit].
    slope : tuple[float, ...]
        ``w_i / h_i``, so that ``t = Σ slope_i (ln x_i − c_i)`` [-].
    linear, quadratic : float
        ``a`` and ``q`` [-].
    amplitude : float
        ``C / M`` [-].
    """

    center: tuple[float, ...]
    slope: tuple[float, ...]
    linear: float
    quadratic: float
    amplitude: float

    def t(self, ln_x: Sequence[float]) -> float:
        """The ridge coordinate ``t`` at ``ln x``."""
        return sum(s * (v - c) for s, c, v in zip(self.slope, self.center, ln_x, strict=True))

    def at(self, ln_x: Sequence[float]) -> float:
        """``C·b(x)``, the bend of ``ln y`` at ``ln x`` [-]."""
        t = self.t(ln_x)
        return self.amplitude * (self.linear * t + self.quadratic * t * t)

    def gradient(self, ln_x: Sequence[float]) -> np.ndarray:
        """``∂(C·b)/∂ ln x`` at ``ln x``."""
        t = self.t(ln_x)
        return self.amplitude * (self.linear + 2.0 * self.quadratic * t) * np.array(self.slope)


def _ridge_max(a: float, q: float) -> float:
    """``max |a t + q t²|`` over ``t ∈ [−1, 1]`` (Bend's ``M``)."""
    best = max(abs(a + q), abs(q - a))
    if q != 0 and abs(a / (2.0 * q)) <= 1.0:
        best = max(best, a * a / (4.0 * abs(q)))
    return best


def fault_rng(seed: int, kind: str) -> np.random.Generator:
    """The RNG stream of fault ``kind`` in the scenario of ``seed`` (module docstring)."""
    return np.random.default_rng([seed, 1 + list(KINDS).index(kind)])


def draw_bends(machine: VirtualMachine, seed: int, curvature: float) -> dict[str, dict[str, Bend]]:
    """A bend per operation (plan order) and model (quantity-name order), scaled by ``C``.

    Each bend draws ``w ~ N(0, I)``, then ``a, q ~ N(0, 1)``, from the stream
    ``fault_rng(seed, "curvature")``; a parameter whose bounds are one value gets ``w_i = 0``.
    ``C = 0`` gives no bends.
    """
    if curvature == 0:
        return {}
    rng = fault_rng(seed, "curvature")
    bends: dict[str, dict[str, Bend]] = {}
    for op, compiled in zip(machine.plan.operations, machine.compiled, strict=True):
        low = np.log([op.bounds[p][0] for p in compiled.parameters])
        high = np.log([op.bounds[p][1] for p in compiled.parameters])
        half = (high - low) / 2.0
        per_model = {}
        for quantity in sorted(q for q, _ in compiled.models):
            w = rng.standard_normal(len(half))
            a, q = rng.standard_normal(2)
            w = np.where(half > 0, w, 0.0)
            norm = float(np.abs(w).sum())
            top = _ridge_max(float(a), float(q))
            if norm == 0 or top == 0:
                continue
            slope = np.divide(w / norm, half, out=np.zeros_like(w), where=half > 0)
            per_model[quantity] = Bend(
                tuple(float(c) for c in (low + high) / 2.0),
                tuple(float(s) for s in slope),
                float(a),
                float(q),
                curvature / top,
            )
        bends[op.name] = per_model
    return bends


@dataclass(frozen=True)
class PartFaults:
    """The faults in force for one part (what :func:`~supervisor.virtual.simulate.run_part` takes).

    Parameters
    ----------
    step_factor : float
        Product of the steps in force: the true maximum model quantities are × this [-].
    noise_scale : float
        True noise over the noise the reported u says [-].
    bends : Mapping[str, Mapping[str, Bend]]
        Per operation and model, its bend (curvature).
    dropouts : Mapping[int, float]
        Reading index (in ``run_part``'s order: operations, then their measured quantities)
        -> the fraction of its true value it comes in at.
    """

    step_factor: float = 1.0
    noise_scale: float = 1.0
    bends: Mapping[str, Mapping[str, Bend]] = field(default_factory=dict)
    dropouts: Mapping[int, float] = field(default_factory=dict)


def step_factor(faults: Faults, part: int) -> float:
    """Product of the factors of the steps in force at part ``part`` (1-based) [-]."""
    factor = 1.0
    for first, f in faults.steps:
        if part >= first:
            factor *= f
    return factor


def readings_per_part(machine: VirtualMachine) -> int:
    """Readings a part of ``machine`` gives (every measured quantity of every operation)."""
    return sum(len(c.measured) for c in machine.compiled)


def part_faults(
    faults: Faults,
    bends: Mapping[str, Mapping[str, Bend]],
    part: int,
    dropout_rng: np.random.Generator,
    readings: int,
) -> PartFaults:
    """The faults in force for part ``part`` (1-based) of a scenario.

    With dropout, every part draws ``readings`` uniforms (does it drop out) and ``readings``
    fractions ``U(0.05, 0.30)`` from ``dropout_rng``, whichever drop out, so a scenario's
    draws depend only on its seed and its part numbers.
    """
    dropouts: dict[int, float] = {}
    if faults.dropout:
        hit = dropout_rng.random(readings)
        fraction = dropout_rng.uniform(*DROPOUT_FRACTION, size=readings)
        dropouts = {j: float(fraction[j]) for j in range(readings) if hit[j] < faults.dropout}
    return PartFaults(
        step_factor=step_factor(faults, part),
        noise_scale=faults.noise_scale_at(part),
        bends=bends,
        dropouts=dropouts,
    )


def true_model_values(
    faults: PartFaults, op: CompiledOperation, values: Mapping[str, float], ln_x: Sequence[float]
) -> dict[str, float]:
    """The power-law truth ``values`` of ``op``'s models, bent and stepped (module docstring)."""
    out = dict(values)
    for quantity, bend in faults.bends.get(op.name, {}).items():
        out[quantity] *= math.exp(bend.at(ln_x))
    if faults.step_factor != 1.0:
        for quantity, _, _ in op.measured:
            out[quantity] *= faults.step_factor
    return out


def reading(
    faults: PartFaults, index: int, true_value: float, sigma: float, z: float
) -> tuple[float, bool]:
    """A reading of ``true_value`` (``index``-th of the part, standard normal ``z``).

    ``F·y_true`` when it drops out, else ``max(y_true + S·σ·z, 0)``; and whether it dropped.
    """
    fraction = faults.dropouts.get(index)
    if fraction is not None:
        return fraction * true_value, True
    return max(true_value + sigma * faults.noise_scale * z, 0.0), False


def unavoidable_parts(faults: Faults, parts: int) -> tuple[int, ...]:
    """The parts at which a violation is unavoidable: part 1, and each step's first part.

    No controller knows a scenario's truth before its first part, nor a step before the first
    part made with it; every other violation is avoidable.
    """
    return tuple(sorted({1} | {p for p, _ in faults.steps if p <= parts}))
