"""A plan's RCB settings and its halt, as the JSON of ``plans.settings`` and ``plans.halt``.

``plans.strategy`` and ``plans.alpha`` keep their columns; every other setting of
:class:`supervisor.rcb.state.RcbSettings` is one key of ``plans.settings`` (NULL, or a key missing:
the default). ``plans.halt`` holds the conflicts of a halted plan in the form the REST
answers show them (``message`` and, per operation, ``operation``, ``message``,
``conflicts`` and ``held_by``; a halt on a reading past its limit by more than ``halt_over`` has
no conflicts and nothing holding it: its ``message`` says which reading).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from supervisor.errors import Conflict
from supervisor.rcb.state import Halt, HaltedOperation, RcbSettings

#: The settings kept in ``plans.settings`` (strategy and alpha have columns of their own).
SETTING_KEYS = (
    "floors",
    "coverage_k",
    "discrepancy",
    "z",
    "exponent_sd",
    "edge_sd",
    "halt_over",
)


def settings_json(settings: RcbSettings) -> dict[str, Any]:
    """``plans.settings`` of ``settings``: every setting but strategy and alpha."""
    return {
        "floors": dict(settings.floors),
        "coverage_k": settings.coverage_k,
        "discrepancy": settings.discrepancy,
        "z": settings.z,
        "exponent_sd": settings.exponent_sd,
        "edge_sd": settings.edge_sd,
        "halt_over": settings.halt_over,
    }


def settings_of(strategy: str, alpha: float, stored: Mapping[str, Any] | None) -> RcbSettings:
    """The :class:`RcbSettings` of a plan's row (``stored``: its ``settings`` column)."""
    given = {k: v for k, v in (stored or {}).items() if k in SETTING_KEYS and v is not None}
    if "floors" in given:
        given["floors"] = {str(q): float(v) for q, v in given["floors"].items()}
    return RcbSettings(strategy=strategy, alpha=alpha, **given)


def halt_json(halt: Halt) -> dict[str, Any]:
    """``plans.halt`` of ``halt``: its message and the conflicts per halted operation."""
    return {
        "message": halt.message,
        "conflicts": [
            {
                "operation": o.operation,
                "message": o.message,
                "conflicts": [
                    {"name": c.name, "limit": c.limit, "required": c.required, "sense": c.sense}
                    for c in o.conflicts
                ],
                "held_by": list(o.against),
            }
            for o in halt.operations
        ],
    }


def halt_of(stored: Mapping[str, Any] | None) -> Halt | None:
    """The :class:`Halt` of ``plans.halt`` (None: the plan runs)."""
    if not stored:
        return None
    return Halt(
        tuple(
            HaltedOperation(
                operation=o["operation"],
                conflicts=tuple(
                    Conflict(c["name"], float(c["limit"]), float(c["required"]), c["sense"])
                    for c in o["conflicts"]
                ),
                against=tuple(o["held_by"]),
                message=o["message"],
            )
            for o in stored["conflicts"]
        )
    )
