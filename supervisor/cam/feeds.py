"""Feeds and speeds of each roughing level and finishing path from the robust optimiser.

Borangiu §4: "each roughing path ``p_i`` should be realized at constant cutting depth ``Δ_j``,
feedrate ``w_j = F`` and spindle speed ``n_j = S``"; "type and hardness of material to be
removed impose upper limits on ``Δ_j``". Here the plan's milling operation (its tool models
with their bands, its limits, its bounds and Borangiu's (w, n) domain, Eqs. 2-7) decides:

- the radial depth limit: the largest ``ae`` for which a robust setpoint exists at the
  operation's least axial depth; the roughing stepover is at most that and half the cutter
  diameter;
- the axial depth limit ``ap_max``: the largest ``ap`` with a robust setpoint at that
  stepover (bisection on ``ln ap``; the force rises with the depth, so feasibility is
  monotone);
- per level: ``ap`` = the level's depth and ``ae`` = the stepover fixed, the optimiser chooses
  ``fz`` and ``vc`` (max MRR or least J, every limit met at the band edge); the spindle speed
  is rounded down to a whole rpm and the feed rate ``fz·z·n`` down to 0.1 mm/min, so the
  program never runs faster than the checked setpoint. A depth or width below the
  operation's lower bound is optimised at that bound (a deeper or wider cut is the harder
  one).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

from models.errors import InputError
from supervisor.cam.cutter import Cutter
from supervisor.errors import InfeasibleError
from supervisor.inputs.plan import Operation, Plan
from supervisor.optimize.optimizer import optimize_operation
from supervisor.optimize.result import OperationResult

#: Bisection steps on ln(ap) and ln(ae): 2^-30 of the bound ratio.
BISECTIONS = 30


@dataclass(frozen=True)
class PathSetpoint:
    """The constant (F, S) of one path and the cut it was chosen for."""

    axial_depth_mm: float
    radial_depth_mm: float
    feed_per_tooth_mm: float
    speed_m_min: float
    spindle_rpm: int
    feed_rate_mm_min: float
    binding: tuple[str, ...]

    def as_json(self) -> dict[str, object]:
        """The setpoint's fields, by name."""
        return {
            "axial_depth_mm": self.axial_depth_mm,
            "radial_depth_mm": self.radial_depth_mm,
            "feed_per_tooth_mm": self.feed_per_tooth_mm,
            "speed_m_min": self.speed_m_min,
            "spindle_rpm": self.spindle_rpm,
            "feed_rate_mm_min": self.feed_rate_mm_min,
            "binding": list(self.binding),
        }


@dataclass(frozen=True)
class CuttingLimits:
    """What the optimiser allows a roughing cutter: ``ap_max`` and the stepover [mm]."""

    max_axial_depth_mm: float
    max_radial_depth_mm: float
    stepover_mm: float


def milling_operation(plan: Plan, name: str, cutter: Cutter, field: str) -> Operation:
    """The plan's milling operation ``name``, checked against the cutter's diameter."""
    found = next((op for op in plan.operations if op.name == name), None)
    if found is None:
        names = ", ".join(op.name for op in plan.operations)
        raise InputError(field, name, f"no such operation in plan {plan.name!r} ({names})")
    if found.process != "milling":
        raise InputError(field, name, f"is a {found.process} operation, not milling")
    diameter = found.context.get("tool_diameter_mm")
    if diameter is None or not math.isclose(diameter, cutter.diameter_mm, rel_tol=1e-9):
        raise InputError(
            field,
            name,
            f"is for a {diameter:g} mm tool, not the {cutter.describe()} given",
        )
    return found


class Feeds:
    """Setpoints of one operation at fixed depths and widths, solved once each."""

    def __init__(self, plan: Plan, operation: Operation) -> None:
        self.plan = plan
        self.operation = operation
        self.tool = plan.tools[operation.tool]
        self._cache: dict[tuple[float, float], PathSetpoint] = {}

    def bounds(self, name: str) -> tuple[float, float]:
        """The operation's ``(low, high)`` of a cutting parameter."""
        return self.operation.bounds[name]

    def _solve(self, ap: float, ae: float) -> OperationResult:
        bounds = dict(self.operation.bounds)
        bounds["axial_depth_mm"] = (ap, ap)
        bounds["radial_depth_mm"] = (ae, ae)
        fixed = replace(self.operation, bounds=bounds, catalog_setpoint={})
        return optimize_operation(fixed, self.tool, self.plan.machine)

    def _feasible(self, ap: float, ae: float) -> bool:
        try:
            self._solve(ap, ae)
        except InfeasibleError:
            return False
        return True

    def _largest(self, low: float, high: float, test: Callable[[float], bool]) -> float:
        """The largest value in ``[low, high]`` that passes ``test`` (monotone), by bisection."""
        if test(high):
            return high
        lo, hi = math.log(low), math.log(high)
        for _ in range(BISECTIONS):
            mid = (lo + hi) / 2
            if test(math.exp(mid)):
                lo = mid
            else:
                hi = mid
        return math.exp(lo)

    def limits(self, cutter: Cutter) -> CuttingLimits:
        """``ap_max``, ``ae_max`` and the stepover (module docstring).

        Raises
        ------
        InfeasibleError
            No robust setpoint even at the least depth and width.
        """
        ap_lo, ap_hi = self.bounds("axial_depth_mm")
        ae_lo, ae_hi = self.bounds("radial_depth_mm")
        self._solve(ap_lo, ae_lo)  # raises InfeasibleError, naming the limits
        ae_max = self._largest(ae_lo, ae_hi, lambda ae: self._feasible(ap_lo, ae))
        stepover = max(ae_lo, min(ae_max, cutter.radius_mm))
        ap_max = self._largest(ap_lo, ap_hi, lambda ap: self._feasible(ap, stepover))
        return CuttingLimits(ap_max, ae_max, stepover)

    def at(self, depth_mm: float, width_mm: float) -> PathSetpoint:
        """The setpoint for a cut ``depth × width`` (each raised to its lower bound)."""
        ap = max(depth_mm, self.bounds("axial_depth_mm")[0])
        ae = max(width_mm, self.bounds("radial_depth_mm")[0])
        key = (round(ap, 9), round(ae, 9))
        if key not in self._cache:
            result = self._solve(ap, ae)
            self._cache[key] = _path_setpoint(result, self.operation)
        return self._cache[key]


def _path_setpoint(result: OperationResult, operation: Operation) -> PathSetpoint:
    sp = result.setpoint
    diameter = operation.context["tool_diameter_mm"]
    flutes = operation.context["flute_count"]
    rpm = math.floor(1000 * sp["speed_m_min"] / (math.pi * diameter))
    rate = math.floor(sp["feed_per_tooth_mm"] * flutes * rpm * 10) / 10
    return PathSetpoint(
        axial_depth_mm=sp["axial_depth_mm"],
        radial_depth_mm=sp["radial_depth_mm"],
        feed_per_tooth_mm=sp["feed_per_tooth_mm"],
        speed_m_min=sp["speed_m_min"],
        spindle_rpm=int(rpm),
        feed_rate_mm_min=rate,
        binding=result.binding,
    )
