"""The ``rcb`` command line: thin commands over the supervisor.

Exit codes: 0 success, 2 bad input (the message names the field and value), 3 infeasible
(the message names the conflicting limits), 4 solver failure.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any

import pydantic
import typer
from rich.console import Console
from rich.progress import Progress
from typer.core import TyperGroup

try:  # recent typer vendors click as typer._click; its exceptions are not click's
    from typer._click import exceptions as click_errors
except ImportError:  # pragma: no cover - typer that uses click itself
    from click import exceptions as click_errors  # type: ignore[no-redef]

from sqlalchemy.exc import ArgumentError, OperationalError

from api.cli import demo_view, tables
from api.cli import review as cli_review
from api.cli.certify import certify
from api.cli.common import (
    DbOption,
    StrategyOption,
    emit,
    err_console,
    errors,
    say,
    shown,
)
from api.cli.fit import fit
from api.cli.gcode import gcode
from api.cli.milling import milling_app
from api.cli.report import report
from api.rest import serving
from api.services import to_json
from api.services.errors import NotFoundError
from api.services.keys import create_key, revoke_key
from api.settings import database_url
from db.engine import make_engine, upgrade
from models import fields
from models.catalogue import get_tool
from models.errors import InputError, ModelDomainError
from models.kinematics import CONTEXT, PARAMETERS
from models.tool import Tool, predict_all
from supervisor.inputs.plan import DEFAULT_FLANK_WEAR_MM, load_plan
from supervisor.optimize.optimizer import optimize_plan
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.strategies import DEFAULT_ALPHA, DEFAULT_STRATEGY
from supervisor.virtual.demo import MILLING_DEMO_UNCERTAINTY, run_demo


class _OneLineErrors(TyperGroup):
    """Report usage errors (a value that is not a number, a missing argument) in one line."""

    def main(
        self,
        args: Sequence[str] | None = None,
        prog_name: str | None = None,
        complete_var: str | None = None,
        standalone_mode: bool = True,
        windows_expand_args: bool = True,
        **extra: Any,
    ) -> Any:
        """Run the command; on a usage error print ``rcb: error: ...`` and exit 2."""
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, False, windows_expand_args, **extra)
        try:
            code = super().main(args, prog_name, complete_var, False, windows_expand_args, **extra)
        except click_errors.NoArgsIsHelpError as err:
            # the error's constructor rendered the help already (typer's rich help prints
            # itself and returns ""); plain click returns it as the message
            text = err.format_message()
            if text.strip():
                typer.echo(text)
            sys.exit(err.exit_code)
        except click_errors.ClickException as err:
            message = " ".join(err.format_message().split())
            if isinstance(err.__cause__, pydantic.ValidationError):  # typer's own coercion
                given = ", ".join(repr(e.get("input")) for e in err.__cause__.errors())
                message = f"{message} (got {given})"
            typer.echo(f"rcb: error: {message}", err=True)
            sys.exit(err.exit_code)
        except typer.Abort:
            typer.echo("rcb: aborted", err=True)
            sys.exit(1)
        sys.exit(code if isinstance(code, int) else 0)


app = typer.Typer(
    cls=_OneLineErrors,
    name="rcb",
    help="Robust optimisation and Recursive Constraint Bounding of cutting parameters.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
_out = Console()
_err = err_console

JsonOption = Annotated[bool, typer.Option("--json", help="Print JSON instead of tables.")]

#: The paper's demonstration part, relative to the directory rcb runs in (the repository).
DEMO_PLAN = Path("examples/ivester_demo_part.toml")
#: The milling demonstration (slot and side finish, spindle current as the force sensor).
MILLING_DEMO_PLAN = Path("examples/milling_demo_part.toml")


def _pairs(items: list[str], option: str) -> dict[str, float]:
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


@app.command()
def predict(
    tool: Annotated[str, typer.Option("--tool", help="Tool name (catalogue or --plan).")],
    depth_mm: Annotated[
        float | None, typer.Option("--depth-mm", help="Turning depth [mm].")
    ] = None,
    feed_mm_rev: Annotated[
        float | None, typer.Option("--feed-mm-rev", help="Turning feed [mm/rev].")
    ] = None,
    speed_m_min: Annotated[
        float | None, typer.Option("--speed-m-min", help="Cutting speed [m/min].")
    ] = None,
    axial_depth_mm: Annotated[
        float | None, typer.Option("--axial-depth-mm", help="Milling axial depth [mm].")
    ] = None,
    radial_depth_mm: Annotated[
        float | None, typer.Option("--radial-depth-mm", help="Milling radial depth [mm].")
    ] = None,
    feed_per_tooth_mm: Annotated[
        float | None, typer.Option("--feed-per-tooth-mm", help="Milling feed per tooth [mm].")
    ] = None,
    workpiece_diameter_mm: Annotated[
        float | None,
        typer.Option("--diameter-mm", help="Turning: workpiece diameter [mm] (adds torque, rpm)."),
    ] = None,
    tool_diameter_mm: Annotated[
        float | None, typer.Option("--tool-diameter-mm", help="Milling: tool diameter [mm].")
    ] = None,
    flute_count: Annotated[
        int | None, typer.Option("--flutes", help="Milling: number of flutes.")
    ] = None,
    flank_wear_mm: Annotated[
        float,
        typer.Option("--flank-wear-mm", help="Allowable flank wear for tool life [mm]."),
    ] = DEFAULT_FLANK_WEAR_MM,
    rel_uncertainty: Annotated[
        list[str] | None,
        typer.Option("--rel-uncertainty", help="Setpoint uncertainty NAME=Δx/x (repeatable)."),
    ] = None,
    plan: Annotated[
        Path | None, typer.Option("--plan", help="Take the tool from this plan file.")
    ] = None,
    as_json: JsonOption = False,
) -> None:
    """Predict every model of a tool, with its band, at one set of cutting parameters."""
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
        found = _tool(tool, plan)
        allowed = PARAMETERS[found.process] + CONTEXT[found.process]
        point: dict[str, float] = {}
        for name, value in given.items():
            option = _OPTIONS[name]
            if value is None:
                if name in PARAMETERS[found.process]:
                    raise InputError(option, None, f"required for {found.process} tool {tool!r}")
                continue
            if name not in allowed:
                raise InputError(option, value, f"not used by {found.process} tool {tool!r}")
            point[name] = fields.number(value, option, positive=True)
        rel = _pairs(rel_uncertainty or [], "--rel-uncertainty")
        for name in rel:
            if name not in PARAMETERS[found.process]:
                raise InputError("--rel-uncertainty", name, "not a cutting parameter of this tool")
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


def _tool(name: str, plan: Path | None) -> Tool:
    if plan is None:
        return get_tool(name, "--tool")
    tools = load_plan(plan).tools
    if name in tools:
        return tools[name]
    return get_tool(name, "--tool")


@app.command()
def optimize(
    plan_file: Annotated[Path, typer.Argument(metavar="PLAN.toml", help="The plan file.")],
    as_json: JsonOption = False,
) -> None:
    """Robust optimum of every operation of a plan: max MRR, every limit met at the band edge."""
    with errors():
        result = optimize_plan(load_plan(plan_file))
    if as_json:
        emit(to_json.plan_json(result))
        return
    _out.print(tables.plan_table(result))
    for op in result.operations:
        table = tables.predictions_table(f"{op.name} ({op.tool})", op.predicted)
        table.caption = tables.setpoint_caption(op)
        _out.print(table)


@app.command()
def demo(
    parts: Annotated[int, typer.Option("--parts", help="Parts made with RCB.", min=1)] = 20,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the virtual lathe.")] = 1,
    strategy: StrategyOption = DEFAULT_STRATEGY,
    alpha: Annotated[
        float, typer.Option("--alpha", help="Fraction of the margin a band shrinks by.")
    ] = DEFAULT_ALPHA,
    plan_file: Annotated[
        Path | None,
        typer.Option("--plan", help="The plan (default: the paper's demonstration part)."),
    ] = None,
    milling: Annotated[
        bool,
        typer.Option(
            "--milling",
            help="The milling demonstration (slot and side finish, spindle current as the "
            "force sensor) on a virtual mill.",
        ),
    ] = False,
    as_json: JsonOption = False,
) -> None:
    """The paper's demonstration: catalogue, robust start, then RCB part by part on a virtual lathe.

    With --milling: a slot and a side-finish pass on a virtual mill whose force is measured by
    the spindle current (Kim & Jeon). Writes nothing: the parts are simulated in memory.
    """
    with errors():
        settings = RcbSettings(strategy=strategy, alpha=alpha)
        if plan_file is None:
            plan_file = MILLING_DEMO_PLAN if milling else DEMO_PLAN
        plan = load_plan(plan_file)
        u = MILLING_DEMO_UNCERTAINTY if milling else None
        if as_json:
            result = run_demo(plan, parts, seed, settings, uncertainty=u)
        else:
            where = "mill" if milling else "lathe"
            with Progress(console=_err, transient=True) as progress:
                task = progress.add_task(f"RCB ({strategy}) on the virtual {where}", total=parts)
                result = run_demo(
                    plan,
                    parts,
                    seed,
                    settings,
                    lambda n: progress.update(task, completed=n),
                    uncertainty=u,
                )
    if as_json:
        emit(demo_view.demo_json(result, strategy, seed))
        return
    for table in demo_view.demo_tables(result):
        _out.print(table)


app.command()(certify)  # rcb certify: api/cli/certify.py
app.command()(fit)  # rcb fit: api/cli/fit.py
app.command()(gcode)  # rcb gcode: api/cli/gcode.py
app.command()(report)  # rcb report: api/cli/report.py
for _review in (
    cli_review.plans,
    cli_review.history,
    cli_review.parts,
    cli_review.export,
    cli_review.replan,
):
    app.command()(_review)  # api/cli/review.py

db_app = typer.Typer(help="The database: migrations.", no_args_is_help=True)
app.add_typer(db_app, name="db")


def _migrate(url: str) -> None:
    try:
        upgrade(url)
    except (ArgumentError, OperationalError) as err:
        raise InputError(
            "--db",
            url,
            f"cannot use this database ({err.__class__.__name__}: {str(err).splitlines()[0]})",
        ) from None


@db_app.command("upgrade")
def db_upgrade(db: DbOption = None) -> None:
    """Create or migrate the database to the newest schema."""
    url = database_url(db)
    with errors():
        _migrate(url)
    say(f"rcb: database {shown(url)} is up to date")


keys_app = typer.Typer(help="API keys of the REST service.", no_args_is_help=True)
app.add_typer(keys_app, name="keys")


@keys_app.command("create")
def keys_create(
    role: Annotated[str, typer.Option(help="mes, engineer or viewer.")],
    label: Annotated[str, typer.Option(help="Who or what the key is for.")] = "",
    db: DbOption = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Create an API key; it is printed once and stored only as a hash."""
    url = database_url(db)
    with errors():
        _migrate(url)
        created = create_key(engine=make_engine(url), role=role, label=label)
    if as_json:
        emit(created)
        return
    typer.echo(created["key"])
    say(f"rcb: key {created['id']} ({created['role']}) created; it is not shown again")


@keys_app.command("revoke")
def keys_revoke(
    key_id: Annotated[int, typer.Argument(metavar="ID", help="The key's id.")],
    db: DbOption = None,
) -> None:
    """Revoke an API key (kept in the audit log, refused from now on)."""
    url = database_url(db)
    with errors():
        _migrate(url)
        try:
            revoked = revoke_key(engine=make_engine(url), key_id=key_id)
        except NotFoundError as err:
            raise InputError("ID", key_id, "no such API key") from err
    say(f"rcb: key {revoked['id']} ({revoked['role']}) revoked")


app.add_typer(milling_app, name="milling")  # rcb milling setup: api/cli/milling.py


@app.command()
def serve(
    db: DbOption = None,
    host: Annotated[str, typer.Option(help="Address to listen on.")] = "127.0.0.1",
    port: Annotated[int, typer.Option(min=1, max=65535, help="TCP port.")] = 8000,
    workers: Annotated[int, typer.Option(min=1, max=64, help="Worker processes.")] = 1,
    access_log: Annotated[bool, typer.Option(help="Log every request.")] = True,
) -> None:
    """Serve the REST API (under /api/v1) with uvicorn; migrates the database first."""
    url = database_url(db)
    with errors():
        _migrate(url)
        say(f"rcb: serving {shown(url)} on http://{host}:{port}/api/v1 ({workers} worker(s))")
        serving.run(url, host=host, port=port, workers=workers, access_log=access_log)
