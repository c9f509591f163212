"""Process plans: the machine, the tools and the operations of one part, read from TOML or JSON.

A plan file holds ``name``, a ``[machine]`` table (limits, sensor calibrations, the control's
resolution: :mod:`supervisor.inputs.resolution`), optional inline ``[[tools]]`` (else tools come
from the catalogue), ``[[operations]]``, optionally ``[rcb]`` (:mod:`supervisor.rcb.settings`).
Every error names the dotted field and its value.

A milling operation may say ``objective = "productivity"`` (default ``"mrr"``: the largest removal
rate) with an ``[operations.productivity]`` table of Borangiu's cost data
(:func:`models.borangiu_cost.productivity_from_mapping`; the coefficient form ``a, b, c
...`` holds for one fixed depth and width, so it is refused here), and ``[operations.domain]`` adds
Borangiu's constraints (:class:`models.borangiu_domain.Domain`) as rows.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from models import fields, quantities
from models.borangiu_cost import CostData
from models.borangiu_domain import Domain
from models.bounds import (
    MAX_FLUTES,
    MAX_OPERATIONS,
    MAX_TOOLS,
    check_count,
)
from models.catalogue import catalogue
from models.errors import Gathered, InputError
from models.kinematics import CONTEXT, DEFAULT_FLANK_WEAR_MM, PARAMETERS, Process
from models.quantities import DERIVED_QUANTITIES, MODEL_QUANTITIES
from models.sensors import Calibration, calibrations_from_mapping
from models.tool import Tool, process_of, tool_body, tool_from_mapping
from supervisor.constant_load.setpoint import ConstantLoadConfig
from supervisor.errors import PlanError
from supervisor.inputs.files import read_document
from supervisor.inputs.milling_tables import borangiu_tables, constant_load_table
from supervisor.inputs.objectives import Objective
from supervisor.inputs.passes import PassSpec, pass_spec, with_depth_bound
from supervisor.inputs.resolution import DEFAULT_RESOLUTION, check_bounds, resolution_from_mapping

#: ``rcb``: the plan's RCB settings, read by :func:`supervisor.rcb.state.plan_settings` where a
#: plan is stored (the settings are RCB's, not the plan's structure).
_PLAN_KEYS = ("name", "machine", "tools", "operations", "description", "rcb")
_OPERATION_KEYS = tuple(
    "name process tool description volume_mm3 limits bounds workpiece_diameter_mm"
    " tool_diameter_mm flute_count allowable_flank_wear_mm setpoint_rel_uncertainty"
    " catalog_setpoint objective productivity domain constant_load stock_mm finish".split()
)


@dataclass(frozen=True)
class Machine:
    """A machine tool and its limits.

    ``limit_of``: limits keyed by machine-limited quantity (``power_kW``; a plan file names it
    by its ``machine_field``, ``max_power_kW``; absent: no limit). ``calibrations``: sensor
    calibrations (:mod:`models.sensors`); ``resolution``: the grid setpoints lie on
    (:mod:`supervisor.inputs.resolution`).
    """

    name: str
    limit_of: Mapping[str, float] = field(default_factory=dict)
    calibrations: Mapping[str, Calibration] = field(default_factory=dict)
    resolution: Mapping[str, float] = field(default_factory=lambda: dict(DEFAULT_RESOLUTION))

    def __post_init__(self) -> None:
        """Every limit bounds a machine-limited quantity of the registry."""
        bounded = set(quantities.machine_fields().values())
        for name in self.limit_of:
            if name not in bounded:
                raise quantities.UnknownQuantityError(
                    "machine", name, f"no machine limit; known: {', '.join(sorted(bounded))}"
                )

    def limits(self) -> dict[str, float]:
        """The machine limits keyed by quantity name (``power_kW`` ...), in registry order."""
        order = quantities.machine_fields().values()
        return {name: self.limit_of[name] for name in order if name in self.limit_of}


@dataclass(frozen=True)
class Operation:
    """One step of a process plan.

    Parameters
    ----------
    name : str
        Unique within the plan.
    process : {"turning", "milling"}
        The process; decides the cutting parameters.
    tool : str
        Name of the tool (inline or catalogue).
    volume_mm3 : float
        Material the operation removes per part [mm³].
    limits : Mapping[str, float]
        Allowable maxima keyed by quantity (``force_N`` ...) and ``parts_per_edge``.
    bounds : Mapping[str, tuple[float, float]]
        ``(low, high)`` of every cutting parameter, in its unit.
    context : Mapping[str, float]
        Fixed inputs: diameter, flute count, ``flank_wear_mm`` (the allowable flank wear).
    setpoint_rel_uncertainty : Mapping[str, float]
        Relative uncertainty ``Δx/x`` of the cutting parameters as the machine holds them [-].
    catalog_setpoint : Mapping[str, float]
        The shop's current parameters (tool maker's catalogue), for comparison; may be empty.
    objective : {"mrr", "productivity"}
        Maximise the removal rate, or minimise Borangiu's cost ``J`` (milling).
    productivity : CostData, optional
        Cost data of ``J``; required for ``objective = "productivity"``. With the ``"mrr"``
        objective it only prices the optimum.
    domain : Domain, optional
        Borangiu's constraints (Eqs. 2-7) on the pitch feed ``fz·z``, feed rate, spindle speed
        and power (milling).
    constant_load : ConstantLoadConfig, optional
        Constant-load control of the spindle current (Tai et al., milling): its setpoints carry
        the reference current and feed limits (:mod:`supervisor.constant_load.setpoint`).
    passes : PassSpec, optional
        ``stock_mm`` cut in whole passes, maybe with a finish (:mod:`supervisor.inputs.passes`).
    """

    name: str
    process: Process
    tool: str
    volume_mm3: float
    limits: Mapping[str, float]
    bounds: Mapping[str, tuple[float, float]]
    context: Mapping[str, float]
    setpoint_rel_uncertainty: Mapping[str, float] = field(default_factory=dict)
    description: str = ""
    catalog_setpoint: Mapping[str, float] = field(default_factory=dict)
    objective: Objective = "mrr"
    productivity: CostData | None = None
    domain: Domain | None = None
    constant_load: ConstantLoadConfig | None = None
    passes: PassSpec | None = None


@dataclass(frozen=True)
class Plan:
    """The ordered operations of one part on one machine, with the tools they use."""

    name: str
    machine: Machine
    tools: Mapping[str, Tool]
    operations: tuple[Operation, ...]
    description: str = ""


def load_plan(path: Path, label: str = "plan file") -> Plan:
    """Read a plan file (:func:`read_plan`); errors name the file (``label``) and the field."""
    return plan_from_mapping(read_plan(path, label))


def read_plan(path: Path, label: str = "plan file") -> object:
    """A plan file's structure: ``*.json`` as JSON, else TOML, a JSON ``null`` as left out.

    The one reader of a plan file (``rcb optimize``, ``demo --plan``, ``certify``, ``plans
    create``), so a JSON plan that ``POST /plans`` takes is taken by each (:func:`plan_body`).
    """
    data = read_document(path, label)
    return plan_body(data) if isinstance(data, Mapping) else data


def plan_body(data: Mapping[str, Any]) -> dict[str, Any]:
    """A JSON plan as the reader and the database take it: a ``null`` field as one left out.

    JSON may spell an optional field ``null`` where a TOML plan leaves it out. The fields of
    the plan's tables are dropped so (the plan, its machine, each inline tool and its models,
    each operation, ``rcb``); a null in a table of values (a limit, a bound) stays, for
    :func:`plan_from_mapping` to refuse.
    """
    body: dict[str, Any] = fields.without_nulls(data)
    for key in ("machine", "rcb"):
        if key in body:
            body[key] = fields.without_nulls(body[key])
    for key, read in (("tools", tool_body), ("operations", fields.without_nulls)):
        if isinstance(body.get(key), list):
            body[key] = [read(entry) for entry in body[key]]
    return body


def plan_from_mapping(data: object, library: Mapping[str, Tool] | None = None) -> Plan:
    """Build and check a plan from its TOML/JSON structure: the one reader of a plan.

    Tools are looked up inline first, then in ``library`` (e.g. the tools stored in the
    database), then in the packaged catalogue. The name, the machine, each inline tool and
    each operation are read apart and their errors gathered: a plan with several is refused
    with every one (:class:`models.errors.InputErrors`, one line each). The operations are read
    once the machine and the inline tools they use were.
    """
    table = fields.mapping(data, "plan")
    if not table:  # one error, not one per missing part
        raise InputError("plan", {}, "empty; required: name, machine, operations")
    ops_data = table.get("operations")
    if isinstance(ops_data, list):  # counted first: nothing of a plan too long is read
        check_count(len(ops_data), MAX_OPERATIONS, "operations", "operations in a plan")
    fields.only_keys(table, _PLAN_KEYS, "")  # at once: a file of another kind is no plan
    found = Gathered()
    name = found.read(fields.identity_field, table, "name", "")
    description = found.read(fields.text, table, "description", "", default="")
    machine = found.read(_machine, table.get("machine"))
    inline = found.read(_inline_tools, table.get("tools", []))
    known = {**(library or {}), **(inline or {})}
    operations: tuple[Operation, ...] = ()
    if not isinstance(ops_data, list) or not ops_data:
        why = "a plan needs a list of at least one operation"
        found.errors.append(InputError("operations", ops_data, why))
    elif machine is not None and inline is not None:
        operations = _operations(ops_data, known, machine, found)
    found.raise_any()
    assert name is not None and description is not None and machine is not None
    return Plan(
        name=name,
        machine=machine,
        tools={op.tool: known.get(op.tool) or catalogue()[op.tool] for op in operations},
        operations=operations,
        description=description,
    )


def _operations(
    ops_data: list[object], inline: Mapping[str, Tool], machine: Machine, found: Gathered
) -> tuple[Operation, ...]:
    """Each operation read apart, its errors kept in ``found``; a name given twice refused."""
    operations: list[Operation] = []
    for i, op_data in enumerate(ops_data):
        op = found.read(_operation, op_data, f"operations[{i}]", inline, machine)
        if op is not None and any(o.name == op.name for o in operations):
            where = f"operations[{i}].name"
            found.errors.append(PlanError(where, op.name, "duplicate operation name"))
        elif op is not None:
            operations.append(op)
    return tuple(operations)


def _machine(data: object) -> Machine:
    if data is None:
        raise InputError("machine", None, "required table missing")
    table = fields.mapping(data, "machine")
    machine_fields = quantities.machine_fields()
    fields.only_keys(table, ("name", *machine_fields, "calibrations", "resolution"), "machine")
    limits = {
        name: fields.number(table[key], f"machine.{key}", positive=True)
        for key, name in machine_fields.items()
        if key in table
    }
    calibrations = calibrations_from_mapping(table.get("calibrations", {}), "machine.calibrations")
    return Machine(
        name=fields.identity_field(table, "name", "machine"),
        limit_of=limits,
        calibrations=calibrations,
        resolution=resolution_from_mapping(table.get("resolution"), "machine.resolution"),
    )


def _inline_tools(data: object) -> dict[str, Tool]:
    """The plan's ``[[tools]]``, each read apart (every tool's errors at once)."""
    if not isinstance(data, list):
        raise InputError("tools", data, "must be a list of tool tables")
    check_count(len(data), MAX_TOOLS, "tools", "inline tools in a plan")
    found = Gathered()
    tools: dict[str, Tool] = {}
    for i, entry in enumerate(data):
        tool = found.read(tool_from_mapping, entry, f"tools[{i}]")
        if tool is not None and tool.name in tools:
            found.errors.append(PlanError(f"tools[{i}].name", tool.name, "duplicate tool name"))
        elif tool is not None:
            tools[tool.name] = tool
    found.raise_any()
    return tools


def _operation(data: object, path: str, inline: Mapping[str, Tool], machine: Machine) -> Operation:
    table = fields.mapping(data, path)
    fields.only_keys(table, _OPERATION_KEYS, path)
    name = fields.identity_field(table, "name", path)
    tool_name = fields.identity_field(table, "tool", path)
    tool = inline.get(tool_name) or catalogue().get(tool_name)
    if tool is None:
        known = ", ".join(sorted({*inline, *catalogue()}))
        raise PlanError(f"{path}.tool", tool_name, f"unknown tool; known tools: {known}")
    process = process_of(table.get("process", tool.process), f"{path}.process")
    if process != tool.process:
        raise PlanError(f"{path}.process", process, f"tool {tool.name!r} is a {tool.process} tool")
    if "volume_mm3" not in table:
        raise InputError(f"{path}.volume_mm3", None, "required field missing")
    volume = fields.number(table["volume_mm3"], f"{path}.volume_mm3", positive=True)
    context = _context(table, path, process)
    limits = _limits(table.get("limits", {}), f"{path}.limits", tool)
    for quantity in DERIVED_QUANTITIES.values():
        base = quantity.based_on
        limited = quantity.name in {*limits, *machine.limits()}
        if base is not None and limited and base not in tool.models:
            raise PlanError(
                f"{path}.tool",
                tool.name,
                f"{quantity.name} is limited but the tool has no {base} model",
            )
    objective, cost, domain = borangiu_tables(table, path, process, tool)
    rel = fields.number_table(
        table.get("setpoint_rel_uncertainty", {}),
        f"{path}.setpoint_rel_uncertainty",
        PARAMETERS[process],
        minimum=0.0,
    )
    passes = pass_spec(table, path, process, limits, lambda d, p: _limits(d, p, tool), tool.models)
    given = with_depth_bound(table.get("bounds"), f"{path}.bounds", process, passes)
    bounds = _bounds(given, f"{path}.bounds", process)
    check_bounds(bounds, machine.resolution, f"{path}.bounds")
    return Operation(
        name=name,
        process=process,
        tool=tool.name,
        volume_mm3=volume,
        limits=limits,
        bounds=bounds,
        context=context,
        setpoint_rel_uncertainty=rel,
        description=fields.text(table, "description", path, default=""),
        catalog_setpoint=_catalog_setpoint(table.get("catalog_setpoint"), path, process),
        objective=objective,
        productivity=cost,
        domain=domain,
        constant_load=constant_load_table(table, path, process, machine.calibrations),
        passes=passes,
    )


def _catalog_setpoint(data: object, path: str, process: Process) -> dict[str, float]:
    if data is None:
        return {}
    where = f"{path}.catalog_setpoint"
    setpoint = fields.number_table(data, where, PARAMETERS[process], positive=True)
    for param in PARAMETERS[process]:
        if param not in setpoint:
            raise InputError(f"{where}.{param}", None, "required when catalog_setpoint is given")
    return setpoint


def _context(table: Mapping[str, Any], path: str, process: Process) -> dict[str, float]:
    context: dict[str, float] = {}
    for key in CONTEXT[process]:
        if key == "flank_wear_mm":
            continue
        if key not in table:
            raise InputError(f"{path}.{key}", None, f"required for a {process} operation")
        context[key] = fields.number(table[key], f"{path}.{key}", positive=True)
        if key == "flute_count" and not (context[key].is_integer() and context[key] <= MAX_FLUTES):
            why = f"must be a whole number of flutes, at most {MAX_FLUTES}"
            raise InputError(f"{path}.{key}", table[key], why)
    for other in sorted({k for keys in CONTEXT.values() for k in keys} - set(CONTEXT[process])):
        if other in table:
            raise InputError(f"{path}.{other}", table[other], f"not used by a {process} operation")
    wear = fields.optional_number(table, "allowable_flank_wear_mm", path, positive=True)
    context["flank_wear_mm"] = DEFAULT_FLANK_WEAR_MM if wear is None else wear
    return context


def _limits(data: object, path: str, tool: Tool) -> dict[str, float]:
    table = fields.mapping(data, path)
    fields.only_keys(table, quantities.limit_keys(), path)
    limits = {k: fields.number(v, f"{path}.{k}", positive=True) for k, v in table.items()}
    for key in limits:
        needed = quantities.limited_by(key).name
        if needed in MODEL_QUANTITIES and needed not in tool.models:
            raise PlanError(
                f"{path}.{key}", limits[key], f"tool {tool.name!r} has no {needed} model"
            )
    return limits


def _bounds(data: object, path: str, process: Process) -> dict[str, tuple[float, float]]:
    if data is None:
        raise InputError(path, None, "required table missing")
    table = fields.mapping(data, path)
    fields.only_keys(table, PARAMETERS[process], path)
    bounds: dict[str, tuple[float, float]] = {}
    for param in PARAMETERS[process]:
        where = f"{path}.{param}"
        if param not in table:
            raise InputError(where, None, "required: [low, high]")
        pair = table[param]
        if not isinstance(pair, list | tuple) or len(pair) != 2:
            raise InputError(where, pair, "must be [low, high]")
        low = fields.number(pair[0], f"{where}[0]", positive=True)
        high = fields.number(pair[1], f"{where}[1]", positive=True)
        if low > high:
            raise InputError(where, list(pair), f"low {low:g} is above high {high:g}")
        bounds[param] = (low, high)
    return bounds
