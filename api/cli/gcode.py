"""``rcb gcode``: write a plan's current setpoints into the F and S words of a lathe program.

The command reads the setpoints in force (:func:`api.services.queries.current_setpoints`) and each
operation's workpiece diameter (:func:`api.services.queries.get_plan`), rewrites the block ranges
given with ``--map OP=N100:N200`` by :func:`supervisor.gcode.rewrite_program` (which documents the
dialect, the refusals, the warnings and the number formats), and writes ``--out`` atomically, only
when everything succeeded. The program is read as bytes and written back with the same bytes
wherever nothing changed (UTF-8, undecodable bytes carried through unchanged).

Errors follow ``rcb`` (exit 2, one line ``rcb: error: FIELD = VALUE: reason``;
:func:`api.cli.common.errors`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

from api.cli.common import (
    DbOption,
    check_target,
    emit,
    errors,
    existing_engine,
    say,
    write_atomically,
)
from api.cli.tables import new_table
from api.services.errors import NotFoundError
from api.settings import database_url
from models.errors import InputError

if TYPE_CHECKING:
    from sqlalchemy import Engine

    from supervisor.gcode import BlockRange, OperationSetpoint, RewriteResult

_out = Console()

#: How the program's bytes become text and back: the same bytes out for every byte in.
_ENCODING, _BYTES = "utf-8", "surrogateescape"


def gcode(
    plan: Annotated[int, typer.Argument(metavar="PLAN", help="The plan's id (rcb plans).")],
    program: Annotated[
        Path, typer.Option("--program", metavar="IN.nc", help="The lathe program to read.")
    ],
    out: Annotated[
        Path, typer.Option("--out", metavar="OUT.nc", help="Where to write the new program.")
    ],
    mapping: Annotated[
        list[str],
        typer.Option(
            "--map",
            metavar="OP=N100:N200",
            help="An operation and its blocks, first and last included (repeatable).",
        ),
    ],
    db: DbOption = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of a table.")] = False,
) -> None:
    """Write the setpoints in force into the F and S words of each operation's blocks.

    F becomes the feed (G95 mm/rev, or mm/min under G94) and S the speed (G96 m/min, or rpm
    under G97) at the operation's workpiece diameter; every other byte is kept. A program
    whose modes cannot be determined is refused and nothing is written.
    """
    from supervisor.gcode import GcodeError, rewrite_program  # when it runs, not for --help

    with errors():
        ranges = [_range(item) for item in mapping]
        source = _read_program(program)
        target = _target(out, program)
        engine = existing_engine(database_url(db))
        version, setpoints = _setpoints(engine, plan, ranges, mapping)
        try:
            result = rewrite_program(source, setpoints, ranges, program_name=program.name)
        except GcodeError as err:
            if err.field == "map":
                raise InputError("--map", err.value, err.reason) from None
            raise
        write_atomically(target, result.text.encode(_ENCODING, _BYTES))
    if as_json:
        emit(result_json(result, plan, version, program, out))
    else:
        _out.print(_table(result, plan, version))
    for notice in result.warnings:
        at = f"line {notice.line}: " if notice.line is not None else ""
        say(f"rcb: warning: {program.name} {at}{notice.operation}: {notice.message}")
    say(f"rcb: wrote {out} ({len(result.changes)} words changed)")


def _range(item: str) -> BlockRange:
    from supervisor.gcode import GcodeError, parse_range

    try:
        return parse_range(item)
    except GcodeError as err:
        raise InputError("--map", item, err.reason) from None


def _read_program(path: Path) -> str:
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise InputError("--program", str(path), "no such file") from None
    except IsADirectoryError:
        raise InputError("--program", str(path), "is a directory, not a program") from None
    except OSError as err:
        raise InputError("--program", str(path), f"cannot be read ({err.strerror})") from None
    if not data.strip():
        raise InputError("--program", str(path), "is empty")
    return data.decode(_ENCODING, _BYTES)


def _target(out: Path, program: Path) -> Path:
    check_target(out)
    if out.exists() and out.resolve() == program.resolve():
        raise InputError("--out", str(out), "is the input program: write the new one elsewhere")
    return out


def _setpoints(
    engine: Engine, plan_id: int, ranges: list[BlockRange], items: list[str]
) -> tuple[int, dict[str, OperationSetpoint]]:
    """The setpoint version in force and the setpoints of the mapped operations."""
    from api.services import queries  # SQLAlchemy: loaded when the command runs, not for --help
    from supervisor.gcode import OperationSetpoint

    try:
        plan = queries.get_plan(engine=engine, plan_id=plan_id)
        current = queries.current_setpoints(engine=engine, plan_id=plan_id)
    except NotFoundError:
        raise InputError("PLAN", plan_id, "no such plan (rcb plans lists them)") from None
    context = {op["name"]: op for op in plan["operations"]}
    setpoint = {op["name"]: op["setpoint"] for op in current["operations"]}
    chosen: dict[str, OperationSetpoint] = {}
    for r, item in zip(ranges, items, strict=True):
        if r.operation not in context or r.operation not in setpoint:
            known = ", ".join(context)
            raise InputError(
                "--map", item, f"no operation {r.operation!r} in plan {plan_id}; known: {known}"
            )
        op = context[r.operation]
        diameter = op["context"].get("workpiece_diameter_mm")
        if op["process"] != "turning" or diameter is None:
            raise InputError(
                "--map",
                item,
                f"{r.operation!r} is a {op['process']} operation; rcb gcode rewrites turning "
                "operations (feed per revolution, workpiece diameter) only",
            )
        chosen[r.operation] = OperationSetpoint(
            name=r.operation,
            feed_mm_rev=setpoint[r.operation]["feed_mm_rev"],
            speed_m_min=setpoint[r.operation]["speed_m_min"],
            workpiece_diameter_mm=diameter,
        )
    return int(current["setpoint_version"]), chosen


def result_json(
    result: RewriteResult, plan_id: int, version: int, program: Path, out: Path
) -> dict[str, Any]:
    """The result as ``rcb gcode --json`` prints it."""
    return {
        "plan_id": plan_id,
        "setpoint_version": version,
        "program": str(program),
        "out": str(out),
        "operations": [
            {
                "name": r.range.operation,
                "blocks": f"N{r.range.start}:N{r.range.end}",
                "lines": [r.first_line, r.last_line],
                "feed_mm_rev": result.setpoints[r.range.operation].feed_mm_rev,
                "speed_m_min": result.setpoints[r.range.operation].speed_m_min,
                "workpiece_diameter_mm": result.setpoints[r.range.operation].workpiece_diameter_mm,
                "spindle_rpm": result.setpoints[r.range.operation].spindle_rpm,
            }
            for r in result.ranges
        ],
        "changes": [
            {
                "line": c.line,
                "column": c.column,
                "operation": c.operation,
                "old": c.old,
                "new": c.new,
                "quantity": c.quantity,
                "mode": c.mode,
            }
            for c in result.changes
        ],
        "warnings": [
            {"line": w.line, "operation": w.operation, "message": w.message}
            for w in result.warnings
        ],
    }


def _table(result: RewriteResult, plan_id: int, version: int) -> Table:
    table = new_table(
        title=f"plan {plan_id}, setpoint version {version}: {len(result.changes)} words changed",
        title_justify="left",
    )
    for column in ("line", "operation", "old", "new", "mode", "quantity"):
        table.add_column(column, justify="right" if column == "line" else "left")
    for c in result.changes:
        table.add_row(str(c.line), c.operation, c.old, c.new, c.mode, c.quantity)
    return table
