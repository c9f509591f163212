"""What a setpoint carries beyond its parameters and predictions, as a JSON-ready mapping.

``objective`` (max MRR or Borangiu's productivity cost), ``cost_per_kg`` (J at the setpoint,
where the operation has cost data), ``constant_load`` (Tai et al.'s reference current and
feed limits, where the operation runs under constant-load control) and ``robust_by``
(``band``, or ``cone`` where the ``learn`` strategy's learned model held the setpoint). The
REST answers, the CLI's JSON and the database (``setpoints.extras``) all use this one form.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, replace
from typing import Any

from supervisor.constant_load.setpoint import ConstantLoadSetpoint
from supervisor.optimize.result import OperationResult


def extras_of(result: OperationResult) -> dict[str, Any]:
    """``objective``, ``cost_per_kg``, ``constant_load`` (null where none) and ``robust_by``."""
    extras: dict[str, Any] = {
        "objective": result.objective,
        "cost_per_kg": result.cost_per_kg,
        "constant_load": None,
        "robust_by": result.robust_by,
    }
    c = result.constant_load
    if c is not None:
        extras["constant_load"] = {**asdict(c), "wear_interval_mm": list(c.wear_interval_mm)}
    return extras


def with_extras(result: OperationResult, extras: Mapping[str, Any] | None) -> OperationResult:
    """``result`` with the extras :func:`extras_of` wrote (None: a setpoint stored before them)."""
    if not extras:
        return result
    c = extras.get("constant_load")
    constant_load = None
    if c is not None:
        interval = tuple(c["wear_interval_mm"])
        constant_load = ConstantLoadSetpoint(**{**c, "wear_interval_mm": interval})
    return replace(
        result,
        objective=extras.get("objective", "mrr"),
        cost_per_kg=extras.get("cost_per_kg"),
        constant_load=constant_load,
        robust_by=extras.get("robust_by", "band"),
    )
