"""What a setpoint carries beyond its parameters and predictions, as a JSON-ready mapping.

``objective`` (max MRR or Borangiu's productivity cost), ``cost_per_kg`` (J at the setpoint,
where the operation has cost data), ``constant_load`` (Tai et al.'s reference current and
feed limits, where the operation runs under constant-load control), ``robust_by``
(``band``, or ``cone`` where the ``learn`` strategy's learned model held the setpoint) and
``passes`` (an operation cut in whole passes: :func:`passes_json`). The REST answers, the
CLI's JSON and the database (``setpoints.extras``) all use this one form.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, replace
from typing import Any

from models.powerlaw import Prediction
from supervisor.constant_load.setpoint import ConstantLoadSetpoint
from supervisor.optimize.result import OperationResult, Passes, PassGroup


def extras_of(result: OperationResult) -> dict[str, Any]:
    """``objective``, ``cost_per_kg``, ``constant_load``, ``robust_by``, ``passes`` (null: none)."""
    extras: dict[str, Any] = {
        "objective": result.objective,
        "cost_per_kg": result.cost_per_kg,
        "constant_load": None,
        "robust_by": result.robust_by,
        "passes": None if result.passes is None else passes_json(result.passes),
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
        passes=None if extras.get("passes") is None else _passes(result, extras["passes"]),
    )


def passes_json(passes: Passes) -> dict[str, Any]:
    """The passes as JSON, roughing first.

    ``{"stock_mm", "count", "groups": [{"kind", "count", "depth_mm", "setpoint", "predicted",
    "mrr_cm3_min", "time_min", "binding", "robust_by"}]}``.
    """
    return {
        "stock_mm": passes.stock_mm,
        "count": passes.count,
        "groups": [
            {
                "kind": g.kind,
                "count": g.count,
                "depth_mm": g.depth_mm,
                "setpoint": dict(g.result.setpoint),
                "predicted": {
                    q: {"value": p.value, "band": p.band} for q, p in g.result.predicted.items()
                },
                "mrr_cm3_min": g.result.mrr_cm3_min,
                "time_min": g.result.time_min,
                "binding": list(g.result.binding),
                "robust_by": g.result.robust_by,
            }
            for g in passes.groups
        ],
    }


def _passes(result: OperationResult, data: Mapping[str, Any]) -> Passes:
    """The passes :func:`passes_json` wrote, each group's setpoint as an operation result."""
    groups = tuple(
        PassGroup(
            g["kind"],
            g["count"],
            g["depth_mm"],
            replace(
                result,
                setpoint=dict(g["setpoint"]),
                predicted={q: Prediction(p["value"], p["band"]) for q, p in g["predicted"].items()},
                mrr_cm3_min=g["mrr_cm3_min"],
                time_min=g["time_min"],
                binding=tuple(g["binding"]),
                robust_by=g["robust_by"],
                constant_load=None,
            ),
        )
        for g in data["groups"]
    )
    return Passes(data["stock_mm"], data["count"], groups)
