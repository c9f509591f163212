"""Helpers of the command-line error tests (tests/api/test_cli_errors*.py, and test_bounds.py and
test_openapi_client.py): the demonstration plan as a dict and as TOML, ``rcb`` run in process or
as the installed script, and the error contract: a non-zero exit and one line naming field and
value, no traceback.
"""

from __future__ import annotations

import copy
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tomllib
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from api.cli.main import app

from conftest import DEMO_PLAN

INPUT_ERROR = 2
INFEASIBLE = 3

#: A turning point the catalogue tools accept.
POINT = ["--depth-mm", "2", "--feed-mm-rev", "0.3", "--speed-m-min", "150"]


# --------------------------------------------------------------------------------------------
# helpers


def _rcb() -> str:
    script = Path(sys.executable).parent / "rcb"
    if script.is_file():
        return str(script)
    found = shutil.which("rcb")
    if found is None:
        pytest.skip("the rcb console script is not installed")
    return found


def demo() -> dict[str, Any]:
    """A fresh copy of the demonstration plan as a dict."""
    return copy.deepcopy(_DEMO)


with DEMO_PLAN.open("rb") as _f:
    _DEMO: dict[str, Any] = tomllib.load(_f)

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def _toml_key(key: str) -> str:
    return key if _BARE_KEY.fullmatch(key) else json.dumps(key)


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a valid TOML basic string
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        items = ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in value.items())
        return "{ " + items + " }" if items else "{}"
    raise TypeError(f"cannot write {value!r} as TOML")


def dumps(data: dict[str, Any]) -> str:
    """TOML text of a plan dict: every key ``key = value``, tables and arrays inline."""
    lines = []
    for key, value in data.items():
        if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            body = ",\n".join("  " + _toml_value(v) for v in value)
            lines.append(f"{_toml_key(key)} = [\n{body},\n]")
        else:
            lines.append(f"{_toml_key(key)} = {_toml_value(value)}")
    return "\n".join(lines) + "\n"


def write_plan(tmp_path: Path, data: dict[str, Any], name: str = "plan.toml") -> Path:
    path = tmp_path / name
    path.write_text(dumps(data), encoding="utf-8")
    return path


def invoke(args: Sequence[str]) -> tuple[int, str, str, BaseException | None]:
    """Run ``rcb ARGS`` in-process: exit code, stdout, stderr, exception."""
    result = CliRunner().invoke(app, [str(a) for a in args])
    return result.exit_code, result.stdout, result.stderr, result.exception


def run_rcb(args: Sequence[str], columns: int = 300) -> tuple[int, str, str]:
    """Run the installed ``rcb`` script with stdout/stderr on pipes."""
    env = {**os.environ, "COLUMNS": str(columns)}
    proc = subprocess.run(
        [_rcb(), *map(str, args)], capture_output=True, text=True, env=env, timeout=120
    )
    return proc.returncode, proc.stdout, proc.stderr


def one_line(code: int, stdout: str, stderr: str, expected_code: int, *needles: str) -> str:
    """Check the error contract; return the message line."""
    assert "Traceback" not in stdout and "Traceback" not in stderr, stderr
    assert code == expected_code, (code, stderr)
    assert stdout == "", stdout
    line = stderr.removesuffix("\n")
    assert line.strip(), "empty message on stderr"
    assert "\n" not in line, f"message is not one line:\n{stderr}"
    for needle in needles:
        assert needle in line, f"{needle!r} not in {line!r}"
    return line


def cli_error(args: Sequence[str], expected_code: int, *needles: str) -> str:
    code, stdout, stderr, exc = invoke(args)
    # Anything but SystemExit here is an uncaught exception: a traceback in real use.
    assert exc is None or isinstance(exc, SystemExit), f"uncaught {exc!r}"
    return one_line(code, stdout, stderr, expected_code, *needles)


Mutation = Callable[[dict[str, Any]], object]


def _inline_tool(exponents: dict[str, float], quantity: str = "force_N") -> Mutation:
    """Rough-OD with an inline tool whose only model has ``exponents``."""

    def mutate(data: dict[str, Any]) -> None:
        data["tools"] = [
            {
                "name": "MY-INSERT",
                "process": "turning",
                "models": {quantity: {"K": 2000, "dK": 100, "exponents": exponents}},
            }
        ]
        data["operations"][0]["tool"] = "MY-INSERT"
        data["operations"][0]["limits"] = {"force_N": 2000}

    return mutate


_NEEDS = re.compile(r"force_N <= 50 needs a limit of at least ([0-9.eE+-]+)")
