"""Turning supervisor results into JSON-ready dicts and rich tables for the CLI."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from rich.table import Table

from models.powerlaw import PowerLawModel, Prediction
from models.quantities import DERIVED_QUANTITIES, MODEL_QUANTITIES
from models.tool import Tool
from supervisor.constant_load.setpoint import ToolChange
from supervisor.inputs.part_report import Measurement
from supervisor.optimize.extras import extras_of
from supervisor.optimize.optimizer import OperationResult, PlanResult
from supervisor.rcb.update import Decision
from supervisor.virtual.demo import DemoResult, Row

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
        **extras_of(result),
    }


def plan_json(result: PlanResult) -> dict[str, Any]:
    """A plan's optimum as in ``rcb optimize --json``."""
    return {
        "plan": result.plan,
        "machine": result.machine,
        "operations": [operation_json(op) for op in result.operations],
        "cycle_time_min": result.cycle_time_min,
    }


def tool_change_json(c: ToolChange) -> dict[str, Any]:
    """One reported feed override and whether the tool is due for a change."""
    return {
        "operation": c.operation,
        "feed_override_percent": c.feed_override_percent,
        "commanded_feed_rate_mm_min": c.commanded_feed_rate_mm_min,
        "feed_rate_lower_mm_min": c.feed_rate_lower_mm_min,
        "due": c.due,
        "reason": c.reason,
    }


def decision_json(d: Decision) -> dict[str, Any]:
    """One RCB decision as in a part report's ``updates``."""
    return {
        "operation": d.operation,
        "quantity": d.quantity,
        "action": d.action,
        "margin": d.margin,
        "band_before": d.band_before,
        "band_after": d.band_after,
        "predicted": d.predicted,
        "measured": d.measured,
        "flagged": d.flagged,
        "flag": d.flag,
        "note": d.note,
        "reason": d.reason,
    }


#: How a flagged decision is shown at a glance, per flag (the band grew: never a note).
FLAG_LABELS = {"breach": "BREACH", "above_band": "ABOVE", "below_band": "BELOW"}
#: How a note is shown: information only, the band went through the margin law.
NOTE_LABELS = {"below_band": "note: below band", "above_band": "note: above band"}


def decision_mark(d: Mapping[str, Any]) -> tuple[str, str]:
    """``(label, kind)`` of a decision's JSON: a breach, a reading past the band, or a note.

    ``kind`` names the CSS class (``breach``, ``above-band``, ``below-band``, ``note``); a
    decision stored before flags were kept apart (flagged, no ``flag``) is ``FLAG``/``flagged``;
    neither flag nor note: ``("", "")``.
    """
    flag, note = d.get("flag"), d.get("note")
    if flag in FLAG_LABELS:
        return FLAG_LABELS[flag], flag.replace("_", "-")
    if d.get("flagged"):
        return "FLAG", "flagged"
    if note in NOTE_LABELS:
        return NOTE_LABELS[note], "note"
    return "", ""


def halt_lines(halt: Mapping[str, Any]) -> list[str]:
    """A halt (``plans.halt``) as lines: per operation, each limit and what it would need."""
    lines = []
    for o in halt.get("conflicts", []):
        for c in o["conflicts"]:
            needs = "needs a limit of at least" if c["sense"] == "max" else "can reach at most"
            sign = "<=" if c["sense"] == "max" else ">="
            lines.append(
                f"{o['operation']}: {c['name']} {sign} {c['limit']:.6g} {needs} {c['required']:.4g}"
            )
        if o.get("held_by"):
            lines.append(f"{o['operation']}: held by {', '.join(o['held_by'])}")
    return lines


def model_json(model: PowerLawModel) -> dict[str, Any]:
    """A power-law model with its provenance."""
    return {
        "K": model.K,
        "dK": model.dK,
        "exponents": dict(model.exponents),
        "source": model.source,
        "reference": model.reference,
    }


def tool_json(tool: Tool) -> dict[str, Any]:
    """A tool in the plan-file format, with its baseline models and provenance."""
    return {
        "name": tool.name,
        "process": tool.process,
        "description": tool.description,
        "material": tool.material,
        "source": tool.source,
        "models": {q: model_json(m) for q, m in tool.models.items()},
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


def setpoint_caption(op: OperationResult) -> str | None:
    """Productivity cost and constant-load limits of a setpoint, where it has them."""
    lines = []
    if op.objective != "mrr" or op.cost_per_kg is not None:
        lines.append(f"objective {op.objective}; J = {_fmt(op.cost_per_kg or 0.0)} /kg")
    c = op.constant_load
    if c is not None:
        lines.append(
            f"constant load: {_fmt(c.reference_current_A)} A, feed "
            f"{_fmt(c.feed_rate_lower_mm_min)}-{_fmt(c.feed_rate_upper_mm_min)} mm/min "
            f"(upper set by the {c.upper_governed_by}); change tool at the lower limit"
            + ("" if c.tool_change_by_feed else ": not by feed here, by count")
        )
    return "\n".join(lines) or None


def _row_json(row: Row) -> dict[str, Any]:
    return {
        "setpoint": dict(row.setpoint),
        "mrr_cm3_min": row.mrr_cm3_min,
        "time_min": row.time_min,
        "predicted": predictions_json(row.predicted),
        "measured": {
            q: {"value": m.value, "uncertainty": m.uncertainty} for q, m in row.measured.items()
        },
    }


def demo_json(result: DemoResult, strategy: str, seed: int) -> dict[str, Any]:
    """``rcb demo --json``: rows C, R, final per operation, cycle times, violations."""
    return {
        "strategy": strategy,
        "seed": seed,
        "parts": result.parts,
        "violations": result.violations,
        "flagged": result.flagged,
        "setpoint_version": result.final_state.version,
        "operations": [
            {
                "name": op.name,
                "catalog": None if op.catalog is None else _row_json(op.catalog),
                "robust": _row_json(op.robust),
                "final": _row_json(op.final),
            }
            for op in result.operations
        ],
        "cycle_time_min": dict(result.cycle_time_min),
        "gain_captured": gain_captured(result.cycle_time_min),
    }


def gain_captured(cycle: Mapping[str, float | None]) -> float | None:
    """``(robust − final) / (robust − oracle)``: the share of the oracle's gain RCB earned."""
    robust, final, oracle = cycle.get("robust"), cycle.get("final"), cycle.get("oracle")
    if robust is None or final is None or oracle is None or robust - oracle <= 0:
        return None
    return (robust - final) / (robust - oracle)


def _pm(p: Prediction | None) -> str:
    return "" if p is None else f"{_fmt(p.value)}\n±{p.band:.3g}"


def _meas(m: Measurement | None) -> str:
    return "" if m is None else f"{_fmt(m.value)}\n±{m.uncertainty:.3g}"


def demo_tables(result: DemoResult) -> list[Table]:
    """One Table-5-like table per operation, then the cycle times."""
    tables = []
    for op in result.operations:
        table = Table(title=f"{op.name}", title_justify="left")
        names = tuple(op.robust.setpoint)
        columns: tuple[str, ...] = ("", *(_PARAMETER_HEADINGS.get(p, p) for p in names))
        columns += ("MRR\ncm³/min", "F N\nmodel", "Ra µm\nmodel", "F N\nmeas.", "Ra µm\nmeas.")
        for column in columns:
            table.add_column(column, justify="right", no_wrap=True)
        labelled = (("C", op.catalog), ("R", op.robust), ("final", op.final))
        for label, row in labelled:
            if row is None:
                continue
            s = row.setpoint
            table.add_row(
                label,
                *(_fmt(s[p]) if p in s else "" for p in names),
                _fmt(row.mrr_cm3_min),
                _pm(row.predicted.get("force_N")),
                _pm(row.predicted.get("roughness_um")),
                _meas(row.measured.get("force_N")),
                _meas(row.measured.get("roughness_um")),
            )
        tables.append(table)
    cycle = result.cycle_time_min
    summary = Table(title="cycle time", title_justify="left")
    for column in ("", "min", "vs catalogue", "vs robust"):
        summary.add_column(column, justify="right")
    for label in ("catalog", "robust", "final", "oracle"):
        value = cycle.get(label)
        if value is None:
            continue
        summary.add_row(
            label, _fmt(value), _change(value, cycle["catalog"]), _change(value, cycle["robust"])
        )
    captured = gain_captured(cycle)
    share = "" if captured is None else f"{100 * captured:.0f} % of the oracle's gain, "
    summary.caption = (
        f"{result.parts} parts, {share}{result.violations} true-limit violations, "
        f"{result.flagged} flagged measurements, setpoint version {result.final_state.version}"
    )
    tables.append(summary)
    return tables


def _change(value: float, reference: float | None) -> str:
    return "" if not reference else f"{100 * (value / reference - 1):+.1f} %"
