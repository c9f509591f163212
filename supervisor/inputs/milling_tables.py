"""An operation's milling tables: Borangiu's objective, cost data and domain; Tai's constant load.

Read for :func:`supervisor.inputs.plan.plan_from_mapping`; each error names the dotted field.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from models import fields
from models.borangiu_cost import CostData, productivity_from_mapping
from models.borangiu_domain import Domain, domain_from_mapping
from models.errors import InputError
from models.kinematics import Process
from models.sensors import Calibration, TaiCurrentFeedCalibration
from models.tool import Tool
from supervisor.constant_load.setpoint import ConstantLoadConfig, config_from_mapping, setup_of
from supervisor.errors import PlanError
from supervisor.inputs.objectives import OBJECTIVES, Objective


def constant_load_table(
    table: Mapping[str, Any], path: str, process: Process, calibrations: Mapping[str, Calibration]
) -> ConstantLoadConfig | None:
    """``[operations.constant_load]``, checked against the machine's Tai calibration."""
    if "constant_load" not in table:
        return None
    where = f"{path}.constant_load"
    if process != "milling":
        raise PlanError(where, table["constant_load"], "constant-load control is for milling")
    config = config_from_mapping(table["constant_load"], where, calibrations)
    calibration = calibrations[config.calibration]
    assert isinstance(calibration, TaiCurrentFeedCalibration)  # config_from_mapping checks
    try:
        setup_of(config, calibration)  # refused now rather than at the first setpoint
    except InputError as err:
        raise PlanError(f"{where}.{err.field}", err.value, err.reason) from None
    return config


def borangiu_tables(
    table: Mapping[str, Any], path: str, process: Process, tool: Tool
) -> tuple[Objective, CostData | None, Domain | None]:
    """The objective, cost data and domain of an operation (Borangiu et al., milling only)."""
    given = table.get("objective", "mrr")
    objective = next((o for o in OBJECTIVES if o == given), None)
    if objective is None:
        raise InputError(f"{path}.objective", given, f"expected one of: {', '.join(OBJECTIVES)}")
    for key in ("productivity", "domain"):
        if key in table and process != "milling":
            raise PlanError(f"{path}.{key}", table[key], "Borangiu's model is for milling")
    if objective == "productivity":
        if process != "milling":
            raise PlanError(f"{path}.objective", given, "the productivity cost is for milling")
        if "productivity" not in table:
            raise InputError(f"{path}.productivity", None, "required with this objective")
    domain = domain_from_mapping(table["domain"], f"{path}.domain") if "domain" in table else None
    cost = None
    if "productivity" in table:
        where = f"{path}.productivity"
        raw = fields.mapping(table["productivity"], where)
        coefficient = next((k for k in ("a", "b", "c", "q", "m", "yp") if k in raw), None)
        given_cost = None if coefficient else productivity_from_mapping(raw, where)
        if coefficient is not None or not isinstance(given_cost, CostData):
            key = coefficient or "a"
            raise InputError(
                f"{where}.{key}",
                raw.get(key),
                "the coefficients a, b, c, q, m, yp hold for one depth and width; an "
                "operation's depths vary: give the cost data",
            )
        if given_cost.energy_cost_per_kWh > 0 and "force_N" not in tool.models:
            raise PlanError(
                f"{where}.energy_cost_per_kWh",
                given_cost.energy_cost_per_kWh,
                f"the cutting power comes from the force model; tool {tool.name!r} has none",
            )
        cost = given_cost
    return objective, cost, domain
