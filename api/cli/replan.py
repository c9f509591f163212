"""``rcb replan PLAN``: change limits, bounds, models or RCB settings, re-optimise, store.

The engineer's side of :func:`api.services.plans.replan` (REST ``POST .../replan``): the
options are parsed into the same change document, ``--dry-run`` stores nothing, and the new
setpoint version is audited with the engineer's name (``--by``, default the OS user).
"""

from __future__ import annotations

from typing import Annotated, Any

import typer
from rich.console import Console

from api.cli.common import (
    DbOption,
    MissingOptionError,
    PlanArg,
    RcbOption,
    emit,
    engine_of,
    errors,
    plan_of,
    say,
)
from api.cli.tables import new_table, short_number
from api.cli.who import ByOption, cli_actor
from models.errors import InputError, InputErrors

_out = Console()
#: The options of which a replan needs one (each makes a change; ``--dry-run`` alone does not).
CHANGE_OPTIONS = "--limit/--bound/--model/--rcb/--reset-bands"
#: ``--reason``: why, kept in the replan's audit entry (checked by the use case).
ReasonOption = Annotated[
    str | None,
    typer.Option("--reason", help="Why, one line (kept in the audit log: rcb audit --plan PLAN)."),
]


def replan(
    plan: PlanArg,
    limit: Annotated[
        list[str] | None, typer.Option("--limit", help="OP.QUANTITY=VALUE (VALUE 'none' removes).")
    ] = None,
    bound: Annotated[list[str] | None, typer.Option("--bound", help="OP.PARAM=LO:HI")] = None,
    model: Annotated[
        list[str] | None,
        typer.Option(
            "--model",
            help="TOOL.QUANTITY:K=..,dK=.. (either or both; a model a learn plan has readings"
            " of: with --reset-bands).",
        ),
    ] = None,
    reset_bands: Annotated[
        bool, typer.Option("--reset-bands", help="Back to the tools' baseline bands.")
    ] = False,
    rcb: RcbOption = None,
    reason: ReasonOption = None,
    dry_run: Annotated[
        bool, typer.Option("--dry-run", help="Show the result; store nothing.")
    ] = False,
    db: DbOption = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
    by: ByOption = None,
) -> None:
    """Change limits, bounds or models, re-optimise, show the difference, store a new version.

    ``--rcb NAME=VALUE`` changes an RCB setting of the plan (``--rcb alpha=0.3``).
    """
    from api.services.plans import replan
    from supervisor.rcb.settings import assignments

    with errors():
        actor = cli_actor(by)
        changes = _changes(limit or [], bound or [], model or [], reset_bands)
        if rcb:
            changes["rcb"] = assignments(rcb, "--rcb")
        if not changes:  # the options that make one, not the change document's {}
            raise MissingOptionError(CHANGE_OPTIONS, "none given: nothing to change")
        engine = engine_of(db)
        plan_key = plan_of(engine, plan)
        try:
            written = replan(
                engine=engine,
                plan_id=plan_key,
                changes=changes,
                dry_run=dry_run,
                actor=actor,
                reason=reason,
            )
        except InputError as err:
            raise _as_option(err) from None
    if as_json:
        emit(written.body)
        return
    _show(plan_key, written.body, dry_run)


def _show(plan_key: int, answer: dict[str, Any], dry_run: bool) -> None:
    """The replan's difference as a table and its cycle times."""
    table = new_table(
        title=f"plan {plan_key}: replan" + (" (dry run, nothing stored)" if dry_run else "")
    )
    for column in ("operation", "parameter", "now", "new"):
        table.add_column(
            column, justify="left" if column in ("operation", "parameter") else "right"
        )
    for d in answer["diff"]:
        rows = [(k, old, new) for k, (old, new) in d["setpoint"].items()]
        rows.append(("MRR cm³/min", *d["mrr_cm3_min"]))
        for i, (name, old, new) in enumerate(rows):
            table.add_row(
                d["operation"] if i == 0 else "", name, short_number(old), short_number(new)
            )
        table.add_row("", "binding", ", ".join(d["binding"][0]), ", ".join(d["binding"][1]))
    _out.print(table)
    before, after = answer["cycle_time_min"]
    stored = "not stored" if dry_run else f"stored as setpoint version {answer['setpoint_version']}"
    say(f"rcb: cycle time {before:.4g} -> {after:.4g} min; {stored}")


def _changes(
    limit: list[str], bound: list[str], model: list[str], reset_bands: bool
) -> dict[str, Any]:
    """The change document of the options (as ``POST .../replan`` takes it)."""
    changes: dict[str, Any] = {
        "limits": {k: _limit_value(k, v) for k, v in _pairs(limit, "--limit").items()},
        "bounds": {k: _bounds(k, v) for k, v in _pairs(bound, "--bound").items()},
        "models": dict(_model(m) for m in model),
    }
    if reset_bands:
        changes["reset_bands"] = True
    return {k: v for k, v in changes.items() if v}


#: The change document's parts and the options that fill them.
_OPTIONS = {"limits": "--limit", "bounds": "--bound", "models": "--model", "rcb": "--rcb"}
#: The use case's arguments besides the changes, and their options.
_ARGUMENTS = {"reason": "--reason"}


def _as_option(err: InputError) -> InputError:
    """``err`` named by the option it came from (``--limit rough-od.force_N``, ``--reason``).

    The change document's path (``limits.rough-od.force_N``) is REST's, not the command line's.
    """

    def renamed(one: InputError) -> InputError:
        if one.field in _ARGUMENTS:
            return InputError(_ARGUMENTS[one.field], one.value, one.reason)
        part, _, rest = one.field.partition(".")
        option = _OPTIONS.get(part)
        return InputError(f"{option} {rest}", one.value, one.reason) if option and rest else one

    if isinstance(err, InputErrors):
        return InputErrors([renamed(e) for e in err.errors])
    return renamed(err)


def _pairs(items: list[str], option: str) -> dict[str, str]:
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise InputError(option, item, "must be NAME=VALUE")
        out[key.strip()] = value.strip()
    return out


def _limit_value(key: str, text: str) -> float | None:
    if text.lower() == "none":
        return None
    return _number(text, f"--limit {key}")


def _bounds(key: str, text: str) -> list[float]:
    low, sep, high = text.partition(":")
    if not sep:
        raise InputError(f"--bound {key}", text, "must be LO:HI")
    return [_number(low, f"--bound {key}"), _number(high, f"--bound {key}")]


def _model(text: str) -> tuple[str, dict[str, float]]:
    name, sep, rest = text.partition(":")
    if not sep or not name:
        raise InputError("--model", text, "must be TOOL.QUANTITY:K=..,dK=..")
    values = _pairs([p for p in rest.split(",") if p], f"--model {name}")
    unknown = set(values) - {"K", "dK"}
    if unknown or not values:
        raise InputError(f"--model {name}", rest, "give K=.. and/or dK=..")
    return name, {k: _number(v, f"--model {name} {k}") for k, v in values.items()}


def _number(text: str, field: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise InputError(field, text, "must be a number") from None
