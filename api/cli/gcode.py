"""``rcb gcode``: write a plan's current setpoints into the F and S words of a lathe program.

The command reads the setpoints in force (:func:`api.services.read.setpoints.current_setpoints`) and
each operation's workpiece diameter (:func:`api.services.read.plans.get_plan`), rewrites the block
ranges given with ``--map OP=N100:N200`` by :func:`supervisor.gcode.rewrite_stream` (which documents
the dialect, the refusals, the warnings and the number formats), and writes ``--out`` atomically,
only when everything succeeded. The program is read as bytes and written back with the same bytes
wherever nothing changed (UTF-8, undecodable bytes carried through unchanged).

Bounded whatever the program's size: the program is read a line at a time (a line longer than
:data:`supervisor.gcode.MAX_LINE_BYTES` is refused, and read no further) and the new one
streamed into a temporary file beside ``--out``, synced and renamed only on success
(:func:`api.cli.atomic.written_atomically`; on any error it is removed). Every change and warning
is counted; the table shows the first :data:`SHOWN` changes, stderr the first :data:`SHOWN`
warnings, and ``--json`` lists the first :data:`supervisor.gcode.MAX_LISTED` of each with
``changes_total``/``changes_truncated`` and ``warnings_total``/``warnings_truncated``.

Errors follow ``rcb`` (exit 2, one line ``rcb: error: FIELD = VALUE: reason``;
:func:`api.cli.common.errors`).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

from api.cli.atomic import written_atomically
from api.cli.common import (
    DbOption,
    PlanArg,
    check_target,
    emit,
    engine_of,
    errors,
    plan_of,
    say,
)
from api.cli.tables import new_table
from api.services.errors import NotFoundError
from models.errors import InputError

if TYPE_CHECKING:
    from sqlalchemy import Engine

    from supervisor.gcode import BlockRange, OperationSetpoint, RewriteReport

_out = Console()

#: The most changes the table shows, and warnings stderr shows (the first, in program order);
#: a line after them counts the rest. ``--json`` lists more (``supervisor.gcode.MAX_LISTED``).
SHOWN = 50
#: Where to find what the table or stderr leave out (``supervisor.gcode.MAX_LISTED``, restated
#: so that ``rcb --help`` imports nothing more: a test checks they agree).
_JSON_LISTS = "--json lists the first 1000"
#: The bytes read at a time when checking that the program is not empty.
_CHUNK_BYTES = 1 << 16


def gcode(
    plan: PlanArg,
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
    whose modes cannot be determined, or with a line over 4096 bytes, is refused and nothing
    is written.

    Every change and warning is counted: the table shows the first 50 changes, stderr the
    first 50 warnings, --json the first 1000 of each (changes_total, warnings_total).
    """
    with errors():
        ranges = [_range(item) for item in mapping]
        with _opened(program) as source:
            target = _target(out, program)
            engine = engine_of(db)
            plan_key = plan_of(engine, plan)
            version, setpoints = _setpoints(engine, plan_key, ranges, mapping)
            report = _rewrite(source, program, target, setpoints, ranges)
    if as_json:
        emit(result_json(report, plan_key, version, program, out))
    else:
        _out.print(_table(report, plan_key, version))
        if report.change_count > SHOWN:
            more = report.change_count - SHOWN
            _out.print(f"... and {more} more words changed ({_JSON_LISTS})", soft_wrap=True)
    for notice in report.warnings[:SHOWN]:
        at = f"line {notice.line}: " if notice.line is not None else ""
        say(f"rcb: warning: {program.name} {at}{notice.operation}: {notice.message}")
    if report.warning_count > SHOWN:
        more = report.warning_count - SHOWN
        say(f"rcb: warning: {program.name}: {more} more warnings ({_JSON_LISTS})")
    say(f"rcb: wrote {out} ({report.change_count} words changed)")


def _range(item: str) -> BlockRange:
    from supervisor.gcode import GcodeError, parse_range

    try:
        return parse_range(item)
    except GcodeError as err:
        raise InputError("--map", item, err.reason) from None


class _Program:
    """The program file, read by the rewrite: a read error is an error of ``--program``."""

    def __init__(self, file: IO[bytes], path: Path) -> None:
        self._file, self._path = file, path

    def readline(self, size: int = -1, /) -> bytes:
        """The next line, of at most ``size`` bytes."""
        try:
            return self._file.readline(size)
        except OSError as err:
            raise _unreadable(self._path, err) from None

    def seek(self, offset: int, whence: int = 0, /) -> int:
        """Move to ``offset``."""
        try:
            return self._file.seek(offset, whence)
        except OSError as err:
            raise _unreadable(self._path, err) from None


def _unreadable(path: Path, err: OSError) -> InputError:
    reason = err.strerror or err.__class__.__name__
    return InputError("--program", str(path), f"cannot be read ({reason})")


@contextmanager
def _opened(path: Path) -> Iterator[_Program]:
    """The program, open; refused if missing, a directory, unreadable or empty."""
    try:
        file = path.open("rb")
    except FileNotFoundError:
        raise InputError("--program", str(path), "no such file") from None
    except IsADirectoryError:
        raise InputError("--program", str(path), "is a directory, not a program") from None
    except OSError as err:
        raise _unreadable(path, err) from None
    with file:
        try:
            while (chunk := file.read(_CHUNK_BYTES)) and not chunk.strip():
                pass
        except OSError as err:
            raise _unreadable(path, err) from None
        if not chunk:
            raise InputError("--program", str(path), "is empty")
        if not file.seekable():
            raise InputError("--program", str(path), "is not a file (it is read more than once)")
        yield _Program(file, path)


def _rewrite(
    source: _Program,
    program: Path,
    target: Path,
    setpoints: dict[str, OperationSetpoint],
    ranges: list[BlockRange],
) -> RewriteReport:
    """Stream the new program into ``target``; a ``map`` error is one of ``--map``."""
    from supervisor.gcode import GcodeError, rewrite_stream  # when it runs, not for --help

    try:
        with written_atomically(target) as file:
            return rewrite_stream(source, file, setpoints, ranges, program_name=program.name)
    except GcodeError as err:
        if err.field == "map":
            raise InputError("--map", err.value, err.reason) from None
        raise


def _target(out: Path, program: Path) -> Path:
    check_target(out)
    if out.exists() and out.resolve() == program.resolve():
        raise InputError("--out", str(out), "is the input program: write the new one elsewhere")
    return out


def _setpoints(
    engine: Engine, plan_id: int, ranges: list[BlockRange], items: list[str]
) -> tuple[int, dict[str, OperationSetpoint]]:
    """The setpoint version in force and the setpoints of the mapped operations."""
    # SQLAlchemy: loaded when the command runs, not for --help
    from api.services.read import plans as read_plans
    from api.services.read import setpoints as read_setpoints
    from supervisor.gcode import OperationSetpoint

    try:
        plan = read_plans.get_plan(engine=engine, plan_id=plan_id)
        current = read_setpoints.current_setpoints(engine=engine, plan_id=plan_id)
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
    result: RewriteReport, plan_id: int, version: int, program: Path, out: Path
) -> dict[str, Any]:
    """The result as ``rcb gcode --json`` prints it (the first changes and warnings, counted)."""
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
                "words_changed": result.changes_by_operation[r.range.operation],
            }
            for r in result.ranges
        ],
        "changes_total": result.change_count,
        "changes_truncated": result.change_count - len(result.changes),
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
        "warnings_total": result.warning_count,
        "warnings_truncated": result.warning_count - len(result.warnings),
        "warnings": [
            {"line": w.line, "operation": w.operation, "message": w.message}
            for w in result.warnings
        ],
    }


def _table(result: RewriteReport, plan_id: int, version: int) -> Table:
    table = new_table(
        title=f"plan {plan_id}, setpoint version {version}: {result.change_count} words changed",
        title_justify="left",
    )
    for column in ("line", "operation", "old", "new", "mode", "quantity"):
        table.add_column(column, justify="right" if column == "line" else "left")
    for c in result.changes[:SHOWN]:
        table.add_row(str(c.line), c.operation, c.old, c.new, c.mode, c.quantity)
    return table
