"""An error on an 80-column terminal is filled at its words; to a pipe it stays one line.

Before, ``rcb optimize`` of an infeasible plan wrote its 192-character reason as one line, and
the terminal broke it inside its words (``ba`` / ``nd edge``). ``rcb`` is run as its console
script on a real pseudo-terminal (the operator's) and on a pipe (a script's, a log's).
"""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest
from cli_errors_support import _rcb

from conftest import ROOT

PLAN = (ROOT / "examples" / "virtual_lathe_part.toml").read_text(encoding="utf-8")


def _infeasible(tmp_path: Path) -> Path:
    """The virtual lathe's plan with a force limit of 1 N: no setpoint meets it."""
    plan = tmp_path / "infeasible.toml"
    plan.write_text(PLAN.replace("force_N = 1500", "force_N = 1", 1), encoding="utf-8")
    return plan


def _on_a_terminal(args: list[str], columns: int) -> tuple[int, str]:
    """Exit code and what ``rcb`` wrote to a pseudo-terminal of ``columns`` columns."""
    primary, secondary = os.openpty()
    env = {**os.environ, "COLUMNS": str(columns), "TERM": "xterm"}
    env.pop("NO_COLOR", None)
    proc = subprocess.Popen(args, stdout=secondary, stderr=secondary, env=env)
    os.close(secondary)
    chunks = []
    while True:
        try:
            chunk = os.read(primary, 4096)
        except OSError:  # the terminal closed: rcb is done
            break
        if not chunk:
            break
        chunks.append(chunk)
    os.close(primary)
    return proc.wait(timeout=60), b"".join(chunks).decode().replace("\r\n", "\n")


@pytest.mark.parametrize("columns", [80, 200])
def test_an_error_is_filled_on_a_terminal_and_one_line_on_a_pipe(tmp_path, columns):
    args = [_rcb(), "optimize", str(_infeasible(tmp_path))]
    piped = subprocess.run(args, capture_output=True, text=True, timeout=60, check=False)
    assert piped.returncode == 3
    [line] = piped.stderr.splitlines()  # a script's grep finds it whole
    assert line.startswith("rcb: infeasible: operation 'rough-od'") and len(line) > 120
    code, shown = _on_a_terminal(args, columns)
    assert code == 3
    lines = shown.splitlines()
    assert len(lines) >= 3 and all(len(each) <= 80 for each in lines), lines
    assert all(each.startswith("  ") for each in lines[1:])  # later lines indented by two
    assert re.sub(r"\s+", " ", shown).strip() == line  # the same words, none broken


def test_a_fleet_error_is_one_line_on_a_pipe(tmp_path):
    """``rcb fleet`` filled its errors whatever the output (a log's grep found half of one)."""
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    subprocess.run([_rcb(), "db", "upgrade", "--db", url], capture_output=True, check=True)
    args = [_rcb(), "fleet", "exclude", "--machine", "LATHE-22KW", "--reason", "x", "--db", url]
    piped = subprocess.run(args, capture_output=True, text=True, timeout=60, check=False)
    assert piped.returncode == 2
    [line] = piped.stderr.splitlines()
    assert line.startswith("rcb: error: --machine = 'LATHE-22KW': ") and len(line) > 80, line
    code, shown = _on_a_terminal(args, 80)
    assert code == 2 and all(len(each) <= 80 for each in shown.splitlines()), shown
