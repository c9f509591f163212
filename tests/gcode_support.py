"""Helpers of the ``rcb gcode`` tests (tests/supervisor/test_gcode.py, test_gcode_refusals.py,
test_gcode_cli.py, test_gcode_stream*.py): the sample programs, the setpoints they are
rewritten with, a rewrite, a streamed rewrite, a long program and a refusal, and the command on
the demonstration plan stored in a temporary SQLite database (each file's module fixture
``stored_plan``).
"""

from __future__ import annotations

import io
import tomllib
from collections import defaultdict
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from api.services import read as queries
from api.services.plans import create_plan
from db.engine import make_engine
from supervisor.gcode import (
    GcodeError,
    OperationSetpoint,
    RewriteResult,
    parse_program,
    parse_range,
    rewrite_program,
    rewrite_stream,
)

from conftest import DEMO_PLAN, ROOT
from migrated import migrated

DATA = ROOT / "tests" / "data" / "gcode"

#: Round numbers: n = 1000·200/(π·60) = 1061.03 rpm, f·n = 344.84 mm/min.
ROUGH = OperationSetpoint(
    "rough-od", feed_mm_rev=0.325, speed_m_min=200.0, workpiece_diameter_mm=60
)
#: n = 1000·190/(π·50) = 1209.58 rpm, f·n = 145.15 mm/min.
FINISH = OperationSetpoint(
    "finish-od", feed_mm_rev=0.12, speed_m_min=190.0, workpiece_diameter_mm=50
)
SETPOINTS = {"rough-od": ROUGH, "finish-od": FINISH}


def program(*lines: str, ending: str = "\n") -> str:
    return ending.join(lines) + ending


def rewrite(text: str, *maps: str, setpoints=None) -> RewriteResult:
    return rewrite_program(
        text, setpoints or SETPOINTS, [parse_range(m) for m in maps], program_name="IN.nc"
    )


def assert_only_words_changed(before: str, result: RewriteResult) -> None:
    """Every byte outside the changed F/S words is the same, line by line, endings included."""
    old_lines, new_lines = before.split("\n"), result.text.split("\n")
    assert len(old_lines) == len(new_lines)
    by_line = defaultdict(list)
    for change in result.changes:
        assert change.old[0] in "FfSs" and change.new[0] == change.old[0]
        by_line[change.line].append(change)
    for number, (old, new) in enumerate(zip(old_lines, new_lines, strict=True), start=1):
        expected = old
        for change in sorted(by_line[number], key=lambda c: -c.column):
            start = change.column - 1
            assert expected[start : start + len(change.old)] == change.old
            expected = expected[:start] + change.new + expected[start + len(change.old) :]
        assert new == expected, f"line {number}"


def words(text: str, line: int) -> dict[str, str]:
    """The words of one line: letter → number text (the last one of each letter)."""
    block = parse_program(text)[line - 1]
    return {w.letter: w.number for w in block.words}


def refused(text: str, *maps: str, setpoints=None) -> GcodeError:
    with pytest.raises(GcodeError) as caught:
        rewrite(text, *maps, setpoints=setpoints)
    return caught.value


def _app() -> typer.Typer:
    """``rcb`` itself."""
    from api.cli.main import app as rcb

    return rcb


def store_demo_plan(tmp_path_factory) -> tuple[str, int, dict]:
    """The demonstration plan in a new SQLite database: URL, plan id, setpoints in force."""
    url = f"sqlite:///{tmp_path_factory.mktemp('gcode') / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    body = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
    plan_id = create_plan(engine=engine, body=body).body["id"]
    current = queries.current_setpoints(engine=engine, plan_id=plan_id)
    engine.dispose()
    return url, plan_id, {op["name"]: op["setpoint"] for op in current["operations"]}


def run(args: list[str]):
    return CliRunner().invoke(_app(), ["gcode", *args])


def cli_args(url: str, plan_id: int, out: Path, *extra: str) -> list[str]:
    return [
        str(plan_id),
        "--program",
        str(DATA / "demo_g95_g96.nc"),
        "--out",
        str(out),
        "--map",
        "rough-od=N100:N180",
        "--map",
        "finish-od=N300:N350",
        "--db",
        url,
        *extra,
    ]


THREAD = OperationSetpoint("thread", feed_mm_rev=0.2, speed_m_min=100, workpiece_diameter_mm=50)
#: One part of a long program: block numbers ``{0}``..``{9}`` (``n``, ``n + 10`` ...).
PART = [
    "(PART)",
    "N{0} T0101",
    "N{1} G96 S187 M03",
    "N{2} G00 X62. Z2.",
    "N{3} G71 P{4} Q{6} U0.4 W0.1 F0.25",
    "N{4} G00 X40. F0.12",
    "N{5} G01 Z-20.",
    "N{6} X62.",
    "N{7} G01 Z-110. F0.25",
    "N{8} G32 Z-30. F2.0",
    "N{9} G01 X64. F.3",
]


def stream(data: bytes, *maps: str, listed: int | None = None, setpoints=None):
    """The new program's bytes and the report of :func:`rewrite_stream` on ``data``."""
    target = io.BytesIO()
    report = rewrite_stream(
        io.BytesIO(data),
        target,
        setpoints or {**SETPOINTS, "thread": THREAD},
        [parse_range(m) for m in maps],
        program_name="IN.nc",
        listed=listed,
    )
    return target.getvalue(), report


def long_program(parts: int, ending: str = "\n") -> str:
    """``parts`` parts after a G21 G95 header, each with new block numbers, then M30."""
    lines = ["%", "O1234", "N1 G21 G95 G50 S3000"]
    for part in range(parts):
        first = 100 + 100 * part
        lines += [line.format(*(first + 10 * k for k in range(10))) for line in PART]
    lines += [f"N{100 + 100 * parts} M30", "%"]
    return ending.join(lines) + ending
