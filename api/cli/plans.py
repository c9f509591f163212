"""``rcb plans create FILE`` and ``rcb plans show PLAN``: store a plan by name, read one back.

``create`` is the command line's ``POST /plans``: the same use case
(:func:`api.services.plans.create_plan`), so a plan file is checked, optimised and stored with
setpoint version 1 exactly as over REST, and a name already stored is refused the same way
(``plan_name_taken``: one line, exit 2). ``rcb plans`` (or ``rcb plans list``) lists them
(:func:`api.cli.review.plans`); :mod:`api.cli.main` makes the group.
"""

from __future__ import annotations

import shlex
from collections.abc import Mapping
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console

from api.cli.common import (
    DbOption,
    JsonOption,
    PlanArg,
    RcbOption,
    StrategyOption,
    as_option,
    emit,
    engine_of,
    errors,
    plan_of,
    refused_line,
    say,
    say_filled,
)
from api.cli.tables import PARAMETER_HEADINGS, free_text, new_table, short_number
from api.cli.who import ByOption, cli_actor
from api.report.provenance import (
    CATALOGUE,
    from_catalogue,
    in_plan_order,
    let_go_caption,
    prior_caption,
)
from models.errors import InputError
from supervisor.rcb.strategies import DEFAULT_STRATEGY

if TYPE_CHECKING:
    from rich.table import Table

_out = Console()


class Prior(StrEnum):
    """What ``learn`` starts from (db.fleet.PRIORS)."""

    fleet = "fleet"
    catalogue = "catalogue"


def _prior(value: str | None) -> str | None:
    """``--prior``: one of :class:`Prior` (none: the default), said as ``--strategy`` is.

    Not typer's check of an enum: its message was pydantic's (``Invalid value for '--prior':
    Value error, 'bogus' is not one of 'fleet', 'catalogue'. (got 'bogus')``).
    """
    if value is not None and value not in tuple(Prior):
        raise InputError("--prior", value, f"must be one of {', '.join(Prior)}")
    return value


PriorOption = Annotated[
    str | None,
    typer.Option(
        "--prior",
        metavar=f"<{'|'.join(Prior)}>",
        callback=_prior,
        help="learn's start: fleet (what the stored plans learned with the plan's tools) or "
        "catalogue. [default: fleet where the database holds it]",
        show_default=False,
    ),
]
PlanFile = Annotated[
    Path,
    typer.Argument(
        metavar="FILE",
        help="The plan file: TOML (as rcb optimize reads), or JSON of the same structure "
        "(as POST /plans takes).",
    ),
]


def create(
    plan_file: PlanFile,
    ctx: typer.Context,
    strategy: StrategyOption = DEFAULT_STRATEGY,
    rcb: RcbOption = None,
    prior: PriorOption = None,
    db: DbOption = None,
    as_json: JsonOption = False,
    by: ByOption = None,
) -> None:
    """Store a plan under its name: checked, optimised, setpoint version 1.

    A name names one plan: a name already stored is refused (change that plan with
    ``rcb replan PLAN``, or give the new one another name). Prints the new plan's id, which
    every PLAN argument takes, as it takes the name. The RCB settings are the file's ``[rcb]``
    table, with ``--strategy`` and ``--rcb NAME=VALUE`` over it. ``learn`` starts from what
    the stored plans learned with the same tools (``--prior fleet``, the default where the
    database holds it) or from the tools' catalogue models (``--prior catalogue``).
    """
    from api.services.plans import create_plan
    from supervisor.rcb.settings import assignments

    with errors():
        actor = cli_actor(by)
        body = read_plan_file(plan_file)
        given = assignments(rcb or [], "--rcb")
        source = ctx.get_parameter_source("strategy")
        if source is not None and source.name != "DEFAULT":  # else the file's [rcb] strategy
            given["strategy"] = strategy
        engine = engine_of(db)
        # the file's [rcb] table, the options over it; its errors and the plan's together
        try:
            written = create_plan(engine=engine, body=body, given=given, actor=actor, prior=prior)
        except InputError as err:
            raise as_option(err, ("prior",)) from None
    answer = written.body
    if as_json:
        emit(answer)
        return
    title = f"plan {answer['id']} {answer['name']}: stored, setpoint version 1"
    _out.print(_setpoint_table(title, answer["operations"]))
    _say_prior(answer)
    _say_band_held(answer)
    say_filled(
        f"rcb: plan {answer['id']} {answer['name']}: setpoint version "
        f"{answer['setpoint_version']}, cycle time {answer['cycle_time_min']:.4g} min"
    )
    _say_taken_out(answer, body)


def _say_taken_out(answer: dict[str, Any], body: Mapping[str, Any]) -> None:
    """That the new plan's machine is taken out of the fleet, as ``rcb plans show`` says it.

    ``fleet_out`` is null otherwise (:func:`api.services.plans.create_plan`); the machine is
    the plan file's, as it is stored (:func:`models.fields.identity`).
    """
    if not answer.get("fleet_out"):
        return
    from models.fields import identity  # NumPy: not at import (rcb --help)

    machine = shlex.quote(identity(str(body["machine"]["name"])))
    say_filled(
        f"rcb: out of the fleet: {answer['fleet_out']}; this plan's readings make no new "
        f"plan's prior until rcb fleet include --machine {machine}"
    )


def _say_band_held(answer: dict[str, Any]) -> None:
    """Which operations with a fleet prior start at the catalogue's setpoint, and why.

    A setpoint is the faster of the band's and the learned cone's (``optimize_operation``):
    where the fleet's prior is no narrower than the catalogue's band (few machines, or
    machines that differ), the band's holds, and a prior asked for seems to do nothing.
    """
    held = [
        op["name"]
        for op in answer["operations"]
        if op["name"] in answer["provenance"] and op.get("robust_by") != "cone"
    ]
    if held:
        told = (
            f"rcb: {', '.join(held)}: the first setpoint is the catalogue band's, the "
            "faster: the fleet's prior is not narrower there yet (more machines behind it "
            "narrow it)"
        )  # within 80 columns, as a terminal shows it
        say_filled(told)


def read_plan_file(path: Path, label: str = "FILE") -> dict[str, Any]:
    """A plan file's structure as every command reads it (errors name ``label``).

    :func:`supervisor.inputs.plan.read_plan`: ``.json`` as JSON (a ``null`` as the field left
    out, as ``POST /plans`` takes it), anything else as TOML.
    """
    from supervisor.inputs.plan import read_plan

    data = read_plan(path, label)
    if not isinstance(data, dict):
        raise InputError(label, str(path), "must hold a plan (a table of name, machine ...)")
    return data


def show(plan: PlanArg, db: DbOption = None, as_json: JsonOption = False) -> None:
    """One plan: its operations with limits and bounds, its RCB settings, the setpoints in force.

    A halted plan has no setpoints in force: its halt is shown instead.
    """
    from api.services.errors import PlanHaltedError
    from api.services.read import plans as read_plans
    from api.services.read import setpoints as read_setpoints

    with errors():
        engine = engine_of(db)
        plan_key = plan_of(engine, plan)
        data = read_plans.get_plan(engine=engine, plan_id=plan_key)
        try:
            current: dict[str, Any] | None = read_setpoints.current_setpoints(
                engine=engine, plan_id=plan_key
            )
        except PlanHaltedError:
            current = None
    data["setpoints"] = current
    if as_json:
        emit(data)
        return
    for table in _show_tables(data, current):
        _out.print(table)
    _say_prior(data)
    if not data["provenance"]:  # the report's "Models started from", in the same words
        say(f"rcb: models started from {CATALOGUE}")
    settings = settings_text(data["settings"])
    state = "HALTED (rcb history shows why)" if data["status"] == "halted" else "running"
    refused = [data[k] for k in ("settings_refused", "plan_refused") if data.get(k)]
    if data["status"] != "halted" and refused:
        state = "REFUSED (below)"
    say_filled(f"rcb: plan {data['id']} {data['name']} on {data['machine']}: {state}")
    rule = (
        f"rcb: setpoint version {data['setpoint_version']}, {data['parts']} parts; "
        f"RCB {data['strategy']} alpha={data['alpha']:g} ({settings})"
    )
    say_filled(rule)
    for why in refused:  # its reports are refused until a replan sets it anew
        say(refused_line(data["id"], why))
    if data.get("fleet_out"):  # no new plan's prior starts from it, and why
        say_filled(f"rcb: out of the fleet: {data['fleet_out']}")


def _name_column(table: Table, heading: str) -> None:
    """A column of names (an operation's, a tool's, a part's serial): a digit makes no number.

    Free text (:func:`api.cli.tables.free_text`): where the table is wider than the console,
    a long name is folded, not the other columns' words (``roughness_um``, ``rough-od``).
    """
    table.add_column(heading, overflow="fold")
    free_text(table.columns[-1])


def settings_text(settings: dict[str, Any]) -> str:
    """The RCB settings as ``--rcb`` takes them: ``coverage_k=2, floors.force_N=50, z=4``.

    Not Python's forms (``floors={}``, ``z=4.0``, ``None``): each floor as ``floors.QUANTITY``
    (none: not named, the default), a number in its shortest form to 12 digits (``4``, not
    ``4.0``; a value given as 2.3456789 stays so), no value as ``none``.
    """
    told = []
    for name, value in settings.items():
        if isinstance(value, dict):
            told += [f"{name}.{q}={v:.12g}" for q, v in value.items()]
        elif value is None:
            told.append(f"{name}=none")
        elif isinstance(value, int | float) and not isinstance(value, bool):
            told.append(f"{name}={value:.12g}")
        else:
            told.append(f"{name}={value}")
    return ", ".join(told)


def _spreads(line: Mapping[str, Any]) -> str:
    """``4.1/2.0``: between machines and between a machine's operations, in per cent."""
    machines = f"{100 * line['between_machine_spread']:.1f}"
    operations = line.get("operation_spread")  # none in a prior stored before it was learned
    return machines if operations is None else f"{machines}/{100 * operations:.1f}"


def _say_prior(answer: dict[str, Any]) -> None:
    """Where each fleet prior came from, a row per operation and quantity (none: catalogue).

    ``answer``: a plan's (``rcb plans create``, ``show``); its operations in the plan's
    order, then where each chain's noise prior came from (a row per quantity). Under each
    table, why each part that let a prior go did so (:mod:`api.report.provenance`).
    """
    if not answer["provenance"]:
        return
    order = [op["name"] for op in answer["operations"]]
    provenance = in_plan_order(answer["provenance"], order)
    lines = [(op, line) for op, ps in provenance for line in ps]
    table = new_table(
        title="learn's fleet prior (spread: between machines/between a machine's "
        "operations; --json names the plans and machines)",
        caption=prior_caption(lines, answer),
        caption_justify="left",
    )
    _name_column(table, "operation")
    for column in ("quantity", "plans", "machines", "spread %", "readings"):
        table.add_column(column, overflow="fold")
    _name_column(table, "let go by")  # a part's serial: a name, its digits no number's
    for i, (operation, line) in enumerate(lines):
        table.add_row(
            operation if i == 0 or lines[i - 1][0] != operation else "",
            line["quantity"],
            str(line["plans_total"]),
            str(line["machines_total"]),
            _spreads(line),
            str(line["readings"]),
            line.get("widened_by_part") or "",  # the part that showed it outside the spread
        )
    _out.print(table)
    rest = from_catalogue(answer)
    if rest:  # the table lists the fleet's; these start as a plan without one
        why = "no plan in the fleet measured their tools"
        say_filled(f"rcb: {', '.join(rest)}: from {CATALOGUE} ({why})")
    if answer["noise_provenance"]:
        _out.print(_noise_table(answer["noise_provenance"]))


def _noise_table(noise: list[dict[str, Any]]) -> Table:
    """Where each chain's noise prior came from, a row per quantity."""
    caption = let_go_caption([(line["quantity"], line) for line in noise], "let_go_by_part")
    table = new_table(
        title="learn's noise prior of each measuring chain (fleet; worth: in readings)",
        caption=caption,
        caption_justify="left",
    )
    for column in ("quantity", "noise", "machines", "spread", "worth"):
        table.add_column(column, overflow="fold")
    _name_column(table, "let go by")
    for line in noise:
        table.add_row(
            line["quantity"],
            f"{line['noise_scale']:.2f} x u",
            str(line["machines_total"]),
            f"{100 * line['between_chain_spread']:.0f} %",
            str(line["readings"]),
            line.get("let_go_by_part") or "",  # the part that showed it noisier
        )
    return table


def _show_tables(data: dict[str, Any], current: dict[str, Any] | None) -> list[Table]:
    """The setpoints in force (none for a halted plan), then each operation's limits and bounds."""
    title = f"plan {data['id']} {data['name']}: setpoint version {data['setpoint_version']}"
    tables = [] if current is None else [_setpoint_table(title, current["operations"])]
    limits = new_table(title=f"plan {data['id']} {data['name']}: limits and bounds")
    _name_column(limits, "operation")
    _name_column(limits, "tool")
    cells = [
        (
            [f"{k} {short_number(v)}" for k, v in op["limits"].items()],
            [f"{k} {short_number(lo)}-{short_number(hi)}" for k, (lo, hi) in op["bounds"].items()],
        )
        for op in data["operations"]
    ]
    for i, column in enumerate(("limits", "bounds")):  # a pair on one line, a name folds first
        pairs = [len(pair) for each in cells for pair in each[i]]
        limits.add_column(column, overflow="fold", min_width=max(pairs, default=0))
    for op, (limit, bound) in zip(data["operations"], cells, strict=True):
        limits.add_row(op["name"], op["tool"], "\n".join(limit), "\n".join(bound))
    return [*tables, limits]


def _setpoint_table(title: str, operations: list[dict[str, Any]]) -> Table:
    """One row per operation: tool, each cutting parameter, MRR.

    A parameter's heading is the short one of ``rcb optimize`` (``ae`` over ``mm``): a name
    such as ``radial_depth_mm`` would be folded mid-word at 80 columns.
    """
    table = new_table(title=title)
    params = list(dict.fromkeys(k for op in operations for k in op["setpoint"]))
    _name_column(table, "operation")
    _name_column(table, "tool")
    for p in params:
        table.add_column(PARAMETER_HEADINGS.get(p, p), justify="right")
    table.add_column("MRR\ncm³/min", justify="right")
    for op in operations:
        table.add_row(
            op["name"],
            op["tool"],
            *(short_number(op["setpoint"].get(p)) for p in params),
            short_number(op["mrr_cm3_min"]),
        )
    return table
