"""``rcb predict`` and ``rcb optimize``: a tool's models at one point, a plan's robust optimum.

Both read files only (the catalogue, a plan file) and write nothing; errors follow ``rcb``
(:func:`api.cli.common.errors`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

from api.cli import tables
from api.cli.common import JsonOption, MissingOptionError, emit, errors
from api.cli.plan_file import STORED_HINT, PlanToolsDbOption, file_plan
from models.errors import InputError, ModelDomainError
from models.kinematics import CONTEXT, DEFAULT_FLANK_WEAR_MM, PARAMETERS
from supervisor.errors import InfeasibleError

if TYPE_CHECKING:
    from models.tool import Tool
    from supervisor.optimize.result import OperationResult

_out = Console()


def _pairs(items: list[str], option: str) -> dict[str, float]:
    from models import fields

    result: dict[str, float] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep:
            raise InputError(option, item, "must be NAME=VALUE")
        try:
            number = float(value)
        except ValueError:
            raise InputError(f"{option} {name}", value, "must be a number") from None
        result[name.strip()] = fields.number(number, f"{option} {name}", minimum=0.0)
    return result


_ToolOption = Annotated[str, typer.Option("--tool", help="Tool name (catalogue or --plan).")]
_DepthOption = Annotated[float | None, typer.Option("--depth-mm", help="Turning depth [mm].")]
_FeedOption = Annotated[float | None, typer.Option("--feed-mm-rev", help="Turning feed [mm/rev].")]
_SpeedOption = Annotated[float | None, typer.Option("--speed-m-min", help="Cutting speed [m/min].")]
_AxialOption = Annotated[
    float | None, typer.Option("--axial-depth-mm", help="Milling axial depth [mm].")
]
_RadialOption = Annotated[
    float | None, typer.Option("--radial-depth-mm", help="Milling radial depth [mm].")
]
_FeedPerToothOption = Annotated[
    float | None, typer.Option("--feed-per-tooth-mm", help="Milling feed per tooth [mm].")
]
_DiameterOption = Annotated[
    float | None,
    typer.Option("--diameter-mm", help="Turning: workpiece diameter [mm] (adds torque, rpm)."),
]
_ToolDiameterOption = Annotated[
    float | None, typer.Option("--tool-diameter-mm", help="Milling: tool diameter [mm].")
]
_FlutesOption = Annotated[int | None, typer.Option("--flutes", help="Milling: number of flutes.")]
_FlankWearOption = Annotated[
    float,
    typer.Option("--flank-wear-mm", help="Allowable flank wear for tool life [mm]."),
]
_RelOption = Annotated[
    list[str] | None,
    typer.Option("--rel-uncertainty", help="Setpoint uncertainty NAME=Δx/x (repeatable)."),
]
_PlanOption = Annotated[
    Path | None, typer.Option("--plan", help="Take the tool from this plan file.")
]
_ToolDbOption = Annotated[
    str | None,
    typer.Option(
        "--db",
        help="Take a stored tool from this database (rcb tools list; default:"
        " $RCB_DATABASE_URL when set, else the catalogue alone).",
        show_default=False,
    ),
]


def predict(
    tool: _ToolOption,
    depth_mm: _DepthOption = None,
    feed_mm_rev: _FeedOption = None,
    speed_m_min: _SpeedOption = None,
    axial_depth_mm: _AxialOption = None,
    radial_depth_mm: _RadialOption = None,
    feed_per_tooth_mm: _FeedPerToothOption = None,
    workpiece_diameter_mm: _DiameterOption = None,
    tool_diameter_mm: _ToolDiameterOption = None,
    flute_count: _FlutesOption = None,
    flank_wear_mm: _FlankWearOption = DEFAULT_FLANK_WEAR_MM,
    rel_uncertainty: _RelOption = None,
    plan: _PlanOption = None,
    db: _ToolDbOption = None,
    as_json: JsonOption = False,
) -> None:
    """Predict every model of a tool, with its band, at one set of cutting parameters."""
    # imported here, as in every command: rcb --help and the other commands do not load them
    from api.services import to_json
    from models.tool import predict_all

    given = {
        "depth_mm": depth_mm,
        "feed_mm_rev": feed_mm_rev,
        "speed_m_min": speed_m_min,
        "axial_depth_mm": axial_depth_mm,
        "radial_depth_mm": radial_depth_mm,
        "feed_per_tooth_mm": feed_per_tooth_mm,
        "workpiece_diameter_mm": workpiece_diameter_mm,
        "tool_diameter_mm": tool_diameter_mm,
        "flute_count": None if flute_count is None else float(flute_count),
        "flank_wear_mm": flank_wear_mm,
    }
    with errors():
        found = _tool(tool, plan, db)
        point = _point(found, tool, given)
        rel = _rel_uncertainties(found, rel_uncertainty or [])
        try:
            predicted = predict_all(found, point, rel)
        except ModelDomainError as err:
            raise InputError(_OPTIONS.get(err.field, err.field), err.value, err.reason) from None
    if as_json:
        emit(
            {
                "tool": found.name,
                "process": found.process,
                "point": point,
                "predicted": to_json.predictions_json(predicted),
            }
        )
    else:
        at = ", ".join(f"{k}={v:g}" for k, v in point.items())
        _out.print(tables.predictions_table(f"{found.name} ({found.process}) at {at}", predicted))


def _point(found: Tool, tool: str, given: dict[str, float | None]) -> dict[str, float]:
    """The cutting parameters and context given: each the tool's process needs, none it does not."""
    from models import fields

    allowed = PARAMETERS[found.process] + CONTEXT[found.process]
    point: dict[str, float] = {}
    for name, value in given.items():
        option = _OPTIONS[name]
        if value is None:
            if name in PARAMETERS[found.process]:
                raise MissingOptionError(option, f"required for {found.process} tool {tool!r}")
            continue
        if name not in allowed:
            raise InputError(option, value, f"not used by {found.process} tool {tool!r}")
        point[name] = fields.number(value, option, positive=True)
    return point


def _rel_uncertainties(found: Tool, items: list[str]) -> dict[str, float]:
    """``--rel-uncertainty NAME=Δx/x`` pairs, each naming a cutting parameter of the tool."""
    rel = _pairs(items, "--rel-uncertainty")
    for name in rel:
        if name not in PARAMETERS[found.process]:
            raise InputError("--rel-uncertainty", name, "not a cutting parameter of this tool")
    return rel


_OPTIONS = {
    "depth_mm": "--depth-mm",
    "feed_mm_rev": "--feed-mm-rev",
    "speed_m_min": "--speed-m-min",
    "axial_depth_mm": "--axial-depth-mm",
    "radial_depth_mm": "--radial-depth-mm",
    "feed_per_tooth_mm": "--feed-per-tooth-mm",
    "workpiece_diameter_mm": "--diameter-mm",
    "tool_diameter_mm": "--tool-diameter-mm",
    "flute_count": "--flutes",
    "flank_wear_mm": "--flank-wear-mm",
}


def _tool(name: str, plan: Path | None, db: str | None) -> Tool:
    """``--tool``: a plan file's (``--plan``), else a stored one (``--db``), else the catalogue's.

    Without ``--db`` and ``RCB_DATABASE_URL`` no database is read (nor ``./rcb.db`` created).
    """
    import os

    from api.settings import DATABASE_URL_VAR
    from models.catalogue import get_tool

    if plan is not None and name in (tools := file_plan(plan, db).tools):
        return tools[name]
    if db is None and not os.environ.get(DATABASE_URL_VAR):
        try:
            return get_tool(name, "--tool")
        except InputError as err:
            hint = f"{err.reason}; {STORED_HINT}"
            raise InputError(err.field, err.value, hint) from None
    from api.cli.common import engine_of
    from api.services.read.tools import stored_tool

    stored = stored_tool(engine=engine_of(db), name=name)
    return stored if stored is not None else get_tool(name, "--tool")


def optimize(
    plan_file: Annotated[Path, typer.Argument(metavar="PLAN.toml", help="The plan file.")],
    db: PlanToolsDbOption = None,
    as_json: JsonOption = False,
) -> None:
    """Robust optimum of every operation of a plan: max MRR, every limit met at the band edge.

    Infeasible (exit 3): with --json a problem document on stdout as well, as the REST answers.
    """
    # imported here (the solvers): rcb --help and the other commands do not load them
    from api.services import to_json
    from supervisor.optimize.optimizer import optimize_plan

    with errors():
        try:
            result = optimize_plan(file_plan(plan_file, db))
        except InfeasibleError as err:
            if as_json:
                emit(infeasible_problem(err))
            raise
    if as_json:
        emit(to_json.plan_json(result))
        return
    _out.print(tables.plan_table(result))
    for op in result.operations:
        table = tables.predictions_table(f"{op.name} ({op.tool})", op.predicted)
        _out.print(table)
        caption = tables.setpoint_caption(op)
        if caption is not None:
            _out.print(caption, highlight=False, markup=False)
        if op.passes is not None:
            _out.print(passes_table(op))


def passes_table(op: OperationResult) -> Table:
    """The passes of an operation cut in whole passes: one row per kind, at its setpoint.

    The operation's table above shows the roughing setpoint; the finishing pass's
    predictions are in ``--json`` (``passes.groups``).
    """
    assert op.passes is not None
    p = op.passes
    table = tables.new_table(
        title=f"{op.name}: {p.count} pass{'es' if p.count > 1 else ''} cut "
        f"stock_mm = {tables.fmt(p.stock_mm)}"
    )
    params = [q for q in tables.PARAMETER_HEADINGS if q in op.setpoint]
    table.add_column("passes", overflow="fold")
    table.add_column("n", justify="right")
    for q in params:
        table.add_column(tables.PARAMETER_HEADINGS[q], justify="right")
    table.add_column("MRR\ncm³/min", justify="right")
    table.add_column("time\nmin", justify="right")
    table.add_column("binding")
    for g in p.groups:
        r = g.result
        table.add_row(
            g.kind,
            str(g.count),
            *(tables.fmt(r.setpoint[q]) for q in params),
            tables.fmt(r.mrr_cm3_min),
            tables.fmt(r.time_min),
            "\n".join(r.binding),
        )
    return table


#: The ``type`` of the REST service's infeasible problem (:mod:`api.rest.problems`).
INFEASIBLE_TYPE = "urn:rcb-supervisor:problem:infeasible"


def infeasible_problem(err: InfeasibleError) -> dict[str, Any]:
    """``rcb optimize --json``'s answer to an infeasible plan: the REST 422 problem (RFC 9457).

    The limits in conflict are given as a halted plan's ``conflicts`` are.
    """
    return {
        "type": INFEASIBLE_TYPE,
        "title": "Unprocessable content",
        "status": 422,
        "detail": str(err),
        "code": "infeasible",
        "field": f"operations.{err.operation}.limits",
        "value": err.operation,
        "conflicts": [
            {
                "operation": err.operation,
                "message": str(err),
                "conflicts": [
                    {"name": c.name, "limit": c.limit, "required": c.required, "sense": c.sense}
                    for c in err.conflicts
                ],
                "held_by": list(err.against),
            }
        ],
    }
