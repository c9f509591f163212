"""``rcb gcode``, the command: the demonstration plan stored in a temporary SQLite database, the
written F and S checked against the setpoints in force; its errors in one line, writing nothing.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from gcode_support import DATA, cli_args, program, run, store_demo_plan, words


@pytest.fixture(scope="module")
def stored_plan(tmp_path_factory) -> tuple[str, int, dict]:
    return store_demo_plan(tmp_path_factory)


# --------------------------------------------------------------------------------------------
# the command


def test_cli_writes_the_setpoints_in_force(stored_plan, tmp_path):
    url, plan_id, setpoints = stored_plan
    out = tmp_path / "OUT.nc"
    result = run(cli_args(url, plan_id, out))
    assert result.exit_code == 0, result.stderr
    assert "rcb: wrote" in result.stderr and "5 words changed" in result.stderr
    assert "F0.25" in result.stdout and "rough-od" in result.stdout
    text = out.read_text()
    rough, finish = setpoints["rough-od"], setpoints["finish-od"]
    for line, setpoint in ((9, rough), (19, finish)):  # G96: S in m/min
        assert float(words(text, line)["S"]) == pytest.approx(setpoint["speed_m_min"], abs=1)
    for line, setpoint in ((11, rough), (12, rough), (15, rough), (21, finish)):  # G95
        assert float(words(text, line)["F"]) == pytest.approx(setpoint["feed_mm_rev"], abs=1e-4)
    assert words(text, 11)["F"] == f"{math.floor(rough['feed_mm_rev'] * 1e4) / 1e4}"
    assert words(text, 9)["S"] == "200"  # 199.99999999999991: the speed bound
    source = (DATA / "demo_g95_g96.nc").read_bytes()
    assert len(out.read_bytes().splitlines()) == len(source.splitlines())


def test_cli_json(stored_plan, tmp_path):
    url, plan_id, setpoints = stored_plan
    out = tmp_path / "OUT.nc"
    result = run(cli_args(url, plan_id, out, "--json"))
    assert result.exit_code == 0, result.stderr
    data = json.loads(result.stdout)
    assert data["plan_id"] == plan_id and data["setpoint_version"] == 1
    assert [op["name"] for op in data["operations"]] == ["rough-od", "finish-od"]
    assert data["operations"][0]["lines"] == [8, 16]
    assert data["operations"][0]["workpiece_diameter_mm"] == 60
    assert data["operations"][0]["feed_mm_rev"] == setpoints["rough-od"]["feed_mm_rev"]
    assert [c["line"] for c in data["changes"]] == [9, 11, 12, 15, 21]  # 19: S190 already
    assert {"line", "column", "operation", "old", "new", "quantity", "mode"} == set(
        data["changes"][0]
    )
    assert data["warnings"] == []


def test_cli_g94_g97_program(stored_plan, tmp_path):
    url, plan_id, setpoints = stored_plan
    out = tmp_path / "OUT.nc"
    args = [str(plan_id), "--program", str(DATA / "g94_g97.nc"), "--out", str(out)]
    result = run([*args, "--map", "rough-od=N10:N60", "--db", url, "--json"])
    assert result.exit_code == 0, result.stderr
    sp = setpoints["rough-od"]
    rpm = 1000 * sp["speed_m_min"] / (math.pi * 60)
    assert float(words(out.read_text(), 5)["S"]) == pytest.approx(rpm, abs=1)
    assert float(words(out.read_text(), 7)["F"]) == pytest.approx(sp["feed_mm_rev"] * rpm, abs=0.1)


def _bad_program(tmp_path: Path) -> Path:
    path = tmp_path / "BAD.nc"
    path.write_text(program("N100 G21 G96 S150 M03", "N180 G01 X10. F0.2"))
    return path


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"plan": "999"}, "rcb: error: PLAN = 999: no such plan"),
        ({"map": "nope=N100:N180"}, "rcb: error: --map = 'nope=N100:N180': no operation 'nope'"),
        ({"map": "rough-od=N100"}, "rcb: error: --map = 'rough-od=N100': must be OPERATION="),
        ({"map": "rough-od=N100:N999"}, "rcb: error: --map = 'rough-od=N100:N999': no block N999"),
        ({"program": "missing.nc"}, "rcb: error: --program = '"),
        ({"program": "BAD"}, "rcb: error: BAD.nc line 2 = 'F0.2': the feed mode is not known"),
        ({"db": "nowhere"}, "rcb: error: --db = 'sqlite:///"),
    ],
)
def test_cli_errors_are_one_line_exit_2_and_write_nothing(stored_plan, tmp_path, change, message):
    url, plan_id, _ = stored_plan
    out = tmp_path / "OUT.nc"
    program_path = DATA / "demo_g95_g96.nc"
    if change.get("program") == "BAD":
        program_path = _bad_program(tmp_path)
    elif "program" in change:
        program_path = tmp_path / change["program"]
    db = f"sqlite:///{tmp_path / 'none.db'}" if "db" in change else url
    args = [change.get("plan", str(plan_id)), "--program", str(program_path), "--out", str(out)]
    args += ["--map", change.get("map", "rough-od=N100:N180"), "--db", db]
    result = run(args)
    assert result.exit_code == 2
    assert result.stderr.startswith(message), result.stderr
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert not out.exists()
    assert not (tmp_path / "none.db").exists()


def test_cli_refuses_to_overwrite_the_input(stored_plan, tmp_path):
    url, plan_id, _ = stored_plan
    source = tmp_path / "IN.nc"
    source.write_bytes((DATA / "demo_g95_g96.nc").read_bytes())
    args = [str(plan_id), "--program", str(source), "--out", str(source)]
    result = run([*args, "--map", "rough-od=N100:N180", "--db", url])
    assert result.exit_code == 2
    assert "--out" in result.stderr and "is the input program" in result.stderr
    assert source.read_bytes() == (DATA / "demo_g95_g96.nc").read_bytes()


def test_cli_keeps_bytes_that_are_not_utf8(stored_plan, tmp_path):
    url, plan_id, _ = stored_plan
    source = tmp_path / "IN.nc"
    data = (DATA / "g94_g97.nc").read_bytes().replace(b"(G94 / G97", b"(\xe9\xff G94 / G97")
    source.write_bytes(data.replace(b"\n", b"\r\n"))
    out = tmp_path / "OUT.nc"
    args = [str(plan_id), "--program", str(source), "--out", str(out)]
    result = run([*args, "--map", "rough-od=N10:N60", "--db", url])
    assert result.exit_code == 0, result.stderr
    written = out.read_bytes()
    assert b"(\xe9\xff G94 / G97" in written and written.count(b"\r\n") == data.count(b"\n")
