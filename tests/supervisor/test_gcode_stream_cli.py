"""``rcb gcode`` streamed (issue 29, point 4/5), the command: bounded output (the first changes
listed, all counted), a long line refused in one bounded line, nothing written on an error.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from gcode_support import DATA, cli_args, long_program, run, store_demo_plan

from api.cli import gcode as cli
from supervisor.gcode import MAX_LINE_BYTES, MAX_LISTED


@pytest.fixture(scope="module")
def stored_plan(tmp_path_factory) -> tuple[str, int, dict]:
    return store_demo_plan(tmp_path_factory)


# --------------------------------------------------------------------------------------------
# the command: bounded output, nothing written on an error


def _long_cli_args(url: str, plan_id: int, tmp_path: Path, parts: int) -> tuple[list[str], Path]:
    source = tmp_path / "LONG.nc"
    source.write_text(long_program(parts))
    out = tmp_path / "OUT.nc"
    args = [str(plan_id), "--program", str(source), "--out", str(out)]
    return [*args, "--map", f"rough-od=N100:N{100 + 100 * parts - 10}", "--db", url], out


def test_cli_json_lists_the_first_changes_and_counts_them_all(stored_plan, tmp_path):
    url, plan_id, _ = stored_plan
    args, out = _long_cli_args(url, plan_id, tmp_path, 400)
    result = run([*args, "--json"])
    assert result.exit_code == 0, result.stderr
    data = json.loads(result.stdout)
    assert (data["changes_total"], len(data["changes"])) == (1600, MAX_LISTED)
    assert data["changes_truncated"] == 1600 - MAX_LISTED
    assert (data["warnings_total"], data["warnings_truncated"], len(data["warnings"])) == (
        800,
        0,
        800,
    )
    assert data["operations"][0]["words_changed"] == 1600
    warned = [line for line in result.stderr.splitlines() if line.startswith("rcb: warning:")]
    assert len(warned) == cli.SHOWN + 1
    assert warned[-1] == f"rcb: warning: LONG.nc: {800 - cli.SHOWN} more warnings " + (
        "(--json lists the first 1000)"
    )
    assert result.stderr.endswith("(1600 words changed)\n")
    assert out.read_text().count("F0.") > 1000


def test_cli_table_shows_the_first_fifty(stored_plan, tmp_path):
    url, plan_id, _ = stored_plan
    args, _ = _long_cli_args(url, plan_id, tmp_path, 100)
    result = run(args)
    assert result.exit_code == 0, result.stderr
    assert "400 words changed" in result.stdout
    assert result.stdout.endswith("... and 350 more words changed (--json lists the first 1000)\n")
    assert result.stdout.count("more words changed") == 1
    rows = [line for line in result.stdout.splitlines() if re.match(r"\s*\d+\s+rough-od", line)]
    assert len(rows) == cli.SHOWN


def test_cli_refuses_a_long_line_in_one_bounded_line_and_writes_nothing(stored_plan, tmp_path):
    url, plan_id, _ = stored_plan
    source = tmp_path / "BIG.nc"
    source.write_bytes(b"N100 G21 G95 G96\nN110" + b" F0.1" * 200_000 + b"\nN180 M30\n")
    out = tmp_path / "OUT.nc"
    args = [str(plan_id), "--program", str(source), "--out", str(out)]
    result = run([*args, "--map", "rough-od=N100:N180", "--db", url])
    assert result.exit_code == 2
    assert result.stderr.startswith("rcb: error: BIG.nc line 2 = 'N110 F0.1 F0.1")
    assert "is longer than 4096 bytes" in result.stderr
    assert result.stderr.count("\n") == 1 and len(result.stderr) < 500
    assert sorted(p.name for p in tmp_path.iterdir()) == ["BIG.nc"]


def test_cli_writes_nothing_when_the_end_of_a_long_program_is_refused(stored_plan, tmp_path):
    url, plan_id, _ = stored_plan
    args, out = _long_cli_args(url, plan_id, tmp_path, 2000)
    source = tmp_path / "LONG.nc"
    text = source.read_text().replace("N200090 G01 X64. F.3", "N200090 G98 G01 X64. F.3")
    source.write_text(text)  # the last part's last F: refused once 2 MB are written
    result = run(args)
    assert result.exit_code == 2, result.stderr
    assert result.stderr.startswith("rcb: error: LONG.nc line 22003 = 'F.3': the feed mode is")
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["LONG.nc"]


def test_cli_refuses_a_program_of_only_whitespace(stored_plan, tmp_path):
    url, plan_id, _ = stored_plan
    source = tmp_path / "BLANK.nc"
    source.write_bytes(b" \r\n\t" * 40_000)  # more than one chunk
    args = [str(plan_id), "--program", str(source), "--out", str(tmp_path / "OUT.nc")]
    result = run([*args, "--map", "rough-od=N100:N180", "--db", url])
    assert result.exit_code == 2 and "is empty" in result.stderr


def test_the_help_states_the_caps_as_they_are():
    from api.cli.gcode import gcode

    help_text = " ".join((gcode.__doc__ or "").split())
    assert f"first {cli.SHOWN} changes" in help_text and f"first {cli.SHOWN} warnings" in help_text
    assert f"--json the first {MAX_LISTED} of each" in help_text
    assert f"over {MAX_LINE_BYTES} bytes" in help_text
    assert cli._JSON_LISTS == f"--json lists the first {MAX_LISTED}"


def test_the_cli_reads_what_the_stream_writes(stored_plan, tmp_path):
    url, plan_id, _ = stored_plan
    out = tmp_path / "OUT.nc"
    assert run(cli_args(url, plan_id, out)).exit_code == 0
    assert out.read_bytes().count(b"\n") == (DATA / "demo_g95_g96.nc").read_bytes().count(b"\n")
