"""Turning supervisor results into JSON-ready dicts and rich tables for the CLI."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from rich.table import Table

from models.powerlaw import Prediction
from models.quantities import DERIVED_QUANTITIES, MODEL_QUANTITIES
from supervisor.optimizer import OperationResult, PlanResult

_UNITS = {q.name: q.unit for q in (*MODEL_QUANTITIES.values(), *DERIVED_QUANTITIES.values())}


def predictions_json(predicted: Mapping[str, Prediction]) -> dict[str, dict[str, float]]:
    """``{quantity: {"value", "band"}}``."""
    return {q: {"value": p.value, "band": p.band} for q, p in predicted.items()}


def operation_json(result: OperationResult) -> dict[str, Any]:
    """One operation as in ``rcb optimize --json``."""
    return {
        "name": result.name,
        "tool": result.tool,
        "process": result.process,
        "setpoint": dict(result.setpoint),
        "predicted": predictions_json(result.predicted),
        "mrr_cm3_min": result.mrr_cm3_min,
        "time_min": result.time_min,
        "binding": list(result.binding),
    }


def plan_json(result: PlanResult) -> dict[str, Any]:
    """A plan's optimum as in ``rcb optimize --json``."""
    return {
        "plan": result.plan,
        "machine": result.machine,
        "operations": [operation_json(op) for op in result.operations],
        "cycle_time_min": result.cycle_time_min,
    }


def _fmt(value: float) -> str:
    return f"{value:.4g}" if abs(value) < 1e5 else f"{value:.3e}"


def predictions_table(title: str, predicted: Mapping[str, Prediction]) -> Table:
    """Quantity, unit, value, band, and the band edges."""
    table = Table(title=title)
    for column in ("quantity", "unit", "value", "± band", "lower", "upper"):
        table.add_column(column, justify="left" if column in ("quantity", "unit") else "right")
    for name, p in predicted.items():
        table.add_row(
            name, _UNITS.get(name, ""), _fmt(p.value), _fmt(p.band), _fmt(p.lower), _fmt(p.upper)
        )
    return table


#: Short column headings of the cutting parameters.
_PARAMETER_HEADINGS = {
    "depth_mm": "d\nmm",
    "feed_mm_rev": "f\nmm/rev",
    "axial_depth_mm": "ap\nmm",
    "radial_depth_mm": "ae\nmm",
    "feed_per_tooth_mm": "fz\nmm",
    "speed_m_min": "v\nm/min",
}


def plan_table(result: PlanResult) -> Table:
    """One row per operation: each cutting parameter, MRR, time, binding constraints.

    Fits 80 columns for a turning plan; the tool is in each operation's own table.
    """
    table = Table(title=f"plan {result.plan} on {result.machine}: robust optimum")
    params = [p for p in _PARAMETER_HEADINGS if any(p in op.setpoint for op in result.operations)]
    table.add_column("operation", overflow="fold", min_width=9)
    for p in params:
        table.add_column(_PARAMETER_HEADINGS[p], justify="right", no_wrap=True)
    table.add_column("MRR\ncm³/min", justify="right", no_wrap=True)
    table.add_column("time\nmin", justify="right", no_wrap=True)
    table.add_column("binding", no_wrap=True)
    for op in result.operations:
        values = [_fmt(op.setpoint[p]) if p in op.setpoint else "" for p in params]
        table.add_row(
            op.name, *values, _fmt(op.mrr_cm3_min), _fmt(op.time_min), "\n".join(op.binding)
        )
    table.caption = f"cycle time {result.cycle_time_min:.4g} min"
    return table
