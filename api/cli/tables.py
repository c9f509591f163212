"""Rich tables of the CLI: predictions and a plan's setpoints."""

from __future__ import annotations

from collections.abc import Mapping

from rich.table import Table

from models.powerlaw import Prediction
from models.quantities import DERIVED_QUANTITIES, MODEL_QUANTITIES
from supervisor.optimize.result import OperationResult, PlanResult

_UNITS = {q.name: q.unit for q in (*MODEL_QUANTITIES.values(), *DERIVED_QUANTITIES.values())}


#: Short column headings of the cutting parameters.
PARAMETER_HEADINGS = {
    "depth_mm": "d\nmm",
    "feed_mm_rev": "f\nmm/rev",
    "axial_depth_mm": "ap\nmm",
    "radial_depth_mm": "ae\nmm",
    "feed_per_tooth_mm": "fz\nmm",
    "speed_m_min": "v\nm/min",
}


def fmt(value: float) -> str:
    """A number as the CLI tables print it."""
    return f"{value:.4g}" if abs(value) < 1e5 else f"{value:.3e}"


def predictions_table(title: str, predicted: Mapping[str, Prediction]) -> Table:
    """Quantity, unit, value, band, and the band edges."""
    table = Table(title=title)
    for column in ("quantity", "unit", "value", "± band", "lower", "upper"):
        table.add_column(column, justify="left" if column in ("quantity", "unit") else "right")
    for name, p in predicted.items():
        table.add_row(
            name, _UNITS.get(name, ""), fmt(p.value), fmt(p.band), fmt(p.lower), fmt(p.upper)
        )
    return table


def plan_table(result: PlanResult) -> Table:
    """One row per operation: each cutting parameter, MRR, time, binding constraints.

    Fits 80 columns for a turning plan; the tool is in each operation's own table.
    """
    table = Table(title=f"plan {result.plan} on {result.machine}: robust optimum")
    params = [p for p in PARAMETER_HEADINGS if any(p in op.setpoint for op in result.operations)]
    table.add_column("operation", overflow="fold", min_width=9)
    for p in params:
        table.add_column(PARAMETER_HEADINGS[p], justify="right", no_wrap=True)
    table.add_column("MRR\ncm³/min", justify="right", no_wrap=True)
    table.add_column("time\nmin", justify="right", no_wrap=True)
    table.add_column("binding", no_wrap=True)
    for op in result.operations:
        values = [fmt(op.setpoint[p]) if p in op.setpoint else "" for p in params]
        table.add_row(
            op.name, *values, fmt(op.mrr_cm3_min), fmt(op.time_min), "\n".join(op.binding)
        )
    table.caption = f"cycle time {result.cycle_time_min:.4g} min"
    return table


def setpoint_caption(op: OperationResult) -> str | None:
    """Productivity cost and constant-load limits of a setpoint, where it has them."""
    lines = []
    if op.objective != "mrr" or op.cost_per_kg is not None:
        lines.append(f"objective {op.objective}; J = {fmt(op.cost_per_kg or 0.0)} /kg")
    c = op.constant_load
    if c is not None:
        lines.append(
            f"constant load: {fmt(c.reference_current_A)} A, feed "
            f"{fmt(c.feed_rate_lower_mm_min)}-{fmt(c.feed_rate_upper_mm_min)} mm/min "
            f"(upper set by the {c.upper_governed_by}); change tool at the lower limit"
            + ("" if c.tool_change_by_feed else ": not by feed here, by count")
        )
    return "\n".join(lines) or None
