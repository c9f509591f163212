"""The robust optimum of an operation and of a plan, as frozen results."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

from models.kinematics import Process
from models.powerlaw import Prediction
from models.tool import Tool
from supervisor.constant_load.setpoint import ConstantLoadSetpoint
from supervisor.inputs.objectives import Objective


@dataclass(frozen=True)
class OperationResult:
    """The robust optimum of one operation.

    Parameters
    ----------
    name, tool : str
        Operation and tool.
    process : {"turning", "milling"}
        Which cutting parameters ``setpoint`` holds.
    setpoint : Mapping[str, float]
        The cutting parameters, in the units their names carry.
    predicted : Mapping[str, Prediction]
        Every model and machine quantity at the setpoint with its band.
    mrr_cm3_min : float
        Removal rate [cm³/min].
    time_min : float
        Machining time ``volume / MRR`` [min].
    binding : tuple[str, ...]
        Quantities whose limit, and parameters whose bound, the optimum sits on.
    objective : {"mrr", "productivity"}
        What the optimum is for.
    cost_per_kg : float or None
        Borangiu's productivity cost ``J`` at the setpoint [currency/kg], when the operation
        has cost data.
    constant_load : ConstantLoadSetpoint or None
        Reference current and feed limits, for a milling operation under constant-load
        control (Tai et al.; :mod:`supervisor.constant_load.setpoint`).
    robust_by : {"band", "cone"}
        What keeps the setpoint safe: the bands, or the learned models' cones (``learn``);
        with ``cone``, ``predicted`` holds the learned value and the cone's half-width.
    fallback : OperationResult or None
        With ``cone``: the band program's optimum beside it (not compared; a cache).
    tool_models : Tool or None
        The tool a band optimum was solved with (not compared; what the cache is keyed on).
    passes : Passes or None
        An operation cut in whole passes (``stock_mm``): their count, depths and setpoints
        (:mod:`supervisor.optimize.passes`); ``setpoint`` is then the roughing passes' and
        ``mrr_cm3_min`` the volume over ``time_min``.
    """

    name: str
    tool: str
    process: Process
    setpoint: Mapping[str, float]
    predicted: Mapping[str, Prediction]
    mrr_cm3_min: float
    time_min: float
    binding: tuple[str, ...]
    objective: Objective = "mrr"
    cost_per_kg: float | None = None
    constant_load: ConstantLoadSetpoint | None = None
    robust_by: str = "band"
    fallback: OperationResult | None = field(default=None, compare=False, repr=False)
    tool_models: Tool | None = field(default=None, compare=False, repr=False)
    passes: Passes | None = None


@dataclass(frozen=True)
class PassGroup:
    """The passes of one kind of a multi-pass operation, all at one setpoint.

    ``kind`` is ``roughing`` (the equal passes) or ``finishing``; ``count`` how many;
    ``depth_mm`` the depth of each (turning depth, milling axial depth) [mm]; ``result`` the
    setpoint with its predictions, removal rate and binding constraints, and in
    ``result.time_min`` the time of all ``count`` passes [min].
    """

    kind: Literal["roughing", "finishing"]
    count: int
    depth_mm: float
    result: OperationResult


@dataclass(frozen=True)
class Passes:
    """How an operation's ``stock_mm`` is cut: ``count`` passes, the roughing ones first."""

    stock_mm: float
    count: int
    groups: tuple[PassGroup, ...]


@dataclass(frozen=True)
class PlanResult:
    """The robust optimum of every operation of a plan."""

    plan: str
    machine: str
    operations: tuple[OperationResult, ...]

    @property
    def cycle_time_min(self) -> float:
        """Sum of the operations' machining times [min]."""
        return sum(op.time_min for op in self.operations)
