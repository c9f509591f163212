"""Supervisor results as JSON-ready dicts.

The one shape the REST service, the CLI's ``--json`` and the stored answers share.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from models.powerlaw import PowerLawModel, Prediction
from models.tool import Tool, model_mapping, tool_mapping
from supervisor.constant_load.reported_tool_changes import ToolChange
from supervisor.optimize.extras import extras_of
from supervisor.optimize.result import OperationResult, PlanResult
from supervisor.rcb.decision import Decision


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


def model_json(model: PowerLawModel) -> dict[str, Any]:
    """A power-law model with its provenance."""
    return model_mapping(model, stderr=False)


def tool_json(tool: Tool) -> dict[str, Any]:
    """A tool in the plan-file format, with its baseline models and provenance."""
    return tool_mapping(tool, stderr=False)
