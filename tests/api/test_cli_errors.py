"""Bad input at the ``rcb`` command line: a non-zero exit and one line naming field and value.

Requirement: limits no parameters can meet, inverted bounds, negative or zero limits, unknown
tools or quantities, malformed or missing files give exit code != 0 and a one-line message
naming the offending field/quantity and value, with no traceback; infeasibility says which
limits conflict. Exit codes (``api/cli/main.py``): 2 bad input, 3 infeasible, 4 solver failure.

Most cases run in-process with ``typer.testing.CliRunner`` (click >= 8.2 always keeps stderr
apart in ``result.stderr``); a few run the installed ``rcb`` console script as a subprocess.
Plan files are derived from ``examples/ivester_demo_part.toml``.
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

ROOT = Path(__file__).resolve().parents[2]
DEMO_PLAN = ROOT / "examples" / "ivester_demo_part.toml"

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


def _set(path: str, value: Any) -> Mutation:
    """A mutation setting ``a.b[0].c`` style ``path`` of the plan dict to ``value``."""
    parts = re.findall(r"[^.\[\]]+|\[\d+\]", path)

    def mutate(data: dict[str, Any]) -> None:
        node: Any = data
        for part in parts[:-1]:
            node = node[int(part[1:-1])] if part.startswith("[") else node[part]
        last = parts[-1]
        node[int(last[1:-1]) if last.startswith("[") else last] = value

    return mutate


def _pop(path: str) -> Mutation:
    *head, last = path.split(".")

    def mutate(data: dict[str, Any]) -> None:
        node: Any = data
        for part in head:
            m = re.fullmatch(r"(\w+)\[(\d+)\]", part)
            node = node[m.group(1)][int(m.group(2))] if m else node[part]
        del node[last]

    return mutate


def _rename(path: str, old: str, new: str) -> Mutation:
    def mutate(data: dict[str, Any]) -> None:
        node: Any = data
        for part in path.split("."):
            m = re.fullmatch(r"(\w+)\[(\d+)\]", part)
            node = node[m.group(1)][int(m.group(2))] if m else node[part]
        node[new] = node.pop(old)

    return mutate


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


# --------------------------------------------------------------------------------------------
# plan files: bad input -> exit 2, "rcb: error: FIELD = VALUE: reason"

PLAN_INPUT_ERRORS: list[Any] = [
    pytest.param(
        _set("operations[0].bounds.depth_mm", [3.0, 0.5]),
        ["operations[0].bounds.depth_mm", "[3.0, 0.5]"],
        id="inverted-bounds",
    ),
    pytest.param(
        _set("operations[0].limits.force_N", 0),
        ["operations[0].limits.force_N = 0"],
        id="zero-force-limit",
    ),
    pytest.param(
        _set("operations[0].limits.roughness_um", -1.5),
        ["operations[0].limits.roughness_um", "-1.5"],
        id="negative-roughness-limit",
    ),
    pytest.param(
        _set("operations[0].limits.parts_per_edge", -10),
        ["operations[0].limits.parts_per_edge", "-10"],
        id="negative-parts-per-edge",
    ),
    pytest.param(
        _set("operations[0].limits.force_N", math.inf),
        ["operations[0].limits.force_N", "inf"],
        id="infinite-limit",
    ),
    pytest.param(
        _set("operations[0].limits.force_N", "2000"),
        ["operations[0].limits.force_N", "'2000'"],
        id="limit-not-a-number",
    ),
    pytest.param(
        _set("machine.max_power_kW", 0),
        ["machine.max_power_kW", "0"],
        id="zero-machine-limit",
    ),
    pytest.param(
        _set("machine.max_torque_Nm", -250),
        ["machine.max_torque_Nm", "-250"],
        id="negative-machine-limit",
    ),
    pytest.param(
        _set("operations[0].bounds.depth_mm", [-1.0, 3.0]),
        ["operations[0].bounds.depth_mm[0]", "-1.0"],
        id="negative-bound",
    ),
    pytest.param(
        _set("operations[2].bounds.speed_m_min", [0, 130]),
        ["operations[2].bounds.speed_m_min[0]", "0"],
        id="zero-bound",
    ),
    pytest.param(
        _set("operations[0].volume_mm3", 0),
        ["operations[0].volume_mm3", "0"],
        id="zero-volume",
    ),
    pytest.param(
        _set("operations[1].tool", "NOPE"),
        ["operations[1].tool", "'NOPE'", "CNMG432RN"],
        id="unknown-tool",
    ),
    pytest.param(
        _set("operations[0].limits.forse_N", 100),
        ["operations[0].limits.forse_N", "100", "force_N"],
        id="unknown-limit-quantity",
    ),
    pytest.param(
        _rename("operations[0]", "workpiece_diameter_mm", "workpeice_diameter_mm"),
        ["operations[0].workpeice_diameter_mm", "60"],
        id="misspelt-operation-field",
    ),
    pytest.param(
        _rename("machine", "max_power_kW", "max_powr_kW"),
        ["machine.max_powr_kW", "22"],
        id="misspelt-machine-field",
    ),
    pytest.param(
        _set("operations[3].unknown", True),
        ["operations[3].unknown", "True"],
        id="unknown-operation-field",
    ),
    pytest.param(
        _pop("operations[0].bounds.feed_mm_rev"),
        ["operations[0].bounds.feed_mm_rev", "None", "required"],
        id="missing-bound",
    ),
    pytest.param(
        _pop("operations[0].bounds"),
        ["operations[0].bounds", "required"],
        id="missing-bounds-table",
    ),
    pytest.param(
        _pop("operations[0].volume_mm3"),
        ["operations[0].volume_mm3", "required"],
        id="missing-volume",
    ),
    pytest.param(
        _pop("operations[0].workpiece_diameter_mm"),
        ["operations[0].workpiece_diameter_mm", "required"],
        id="missing-diameter",
    ),
    pytest.param(
        _set("operations[0].bounds.feed_mm_rev", [0.1, 0.3, 0.5]),
        ["operations[0].bounds.feed_mm_rev", "[0.1, 0.3, 0.5]"],
        id="bound-three-numbers",
    ),
    pytest.param(
        _set("operations[0].bounds.feed_mm_rev", 0.3),
        ["operations[0].bounds.feed_mm_rev", "0.3"],
        id="bound-scalar",
    ),
    pytest.param(
        _set("operations[0].bounds.feed_mm_rev", ["low", 0.3]),
        ["operations[0].bounds.feed_mm_rev[0]", "'low'"],
        id="bound-not-numbers",
    ),
    pytest.param(
        _set("operations[0].bounds.axial_depth_mm", [1.0, 2.0]),
        ["operations[0].bounds.axial_depth_mm", "[1.0, 2.0]"],
        id="milling-bound-on-turning",
    ),
    pytest.param(
        _inline_tool({"depth_mm": 0.9, "fed_mm_rev": 0.7}),
        ["tools[0].models.force_N.exponents.fed_mm_rev", "0.7"],
        id="tool-unknown-exponent-variable",
    ),
    pytest.param(
        _inline_tool({"depth_mm": 0.9}, quantity="forse_N"),
        ["tools[0].models.forse_N", "'forse_N'"],
        id="tool-unknown-model-quantity",
    ),
    pytest.param(
        _set("operations", []),
        ["operations = []"],
        id="empty-operations",
    ),
    pytest.param(
        _set("operations[1].name", "rough-od"),
        ["operations[1].name", "'rough-od'", "duplicate"],
        id="duplicate-operation-name",
    ),
    pytest.param(
        _set("operations[1].limits.parts_per_edge", 5),
        ["operations[1].limits.parts_per_edge", "5", "VCMR331", "tool_life_mm3"],
        id="limit-without-model",
    ),
    pytest.param(
        _set("operations[0].process", "milling"),
        ["operations[0].process", "'milling'", "CNMG432RN"],
        id="process-does-not-fit-tool",
    ),
    pytest.param(
        _set("operations[0].process", "drilling"),
        ["operations[0].process", "'drilling'"],
        id="unknown-process",
    ),
    pytest.param(
        _set("operations[0].tool_diameter_mm", 10),
        ["operations[0].tool_diameter_mm", "10"],
        id="milling-diameter-on-turning",
    ),
    pytest.param(
        _set("operations[0].setpoint_rel_uncertainty", {"depth_mm": -0.1}),
        ["operations[0].setpoint_rel_uncertainty.depth_mm", "-0.1"],
        id="negative-setpoint-uncertainty",
    ),
    pytest.param(
        _pop("machine"),
        ["machine", "None", "required"],
        id="missing-machine",
    ),
    pytest.param(
        _set("operations[0].flute_count", 4),
        ["operations[0].flute_count", "4"],
        id="flute-count-on-turning",
    ),
]


@pytest.mark.parametrize(("mutate", "needles"), PLAN_INPUT_ERRORS)
def test_plan_input_error(tmp_path: Path, mutate: Mutation, needles: list[str]) -> None:
    data = demo()
    mutate(data)
    plan = write_plan(tmp_path, data)
    line = cli_error(["optimize", plan], INPUT_ERROR, *needles)
    assert line.startswith("rcb: error: ")


def test_unknown_tool_also_fails_with_json(tmp_path: Path) -> None:
    data = demo()
    data["operations"][1]["tool"] = "NOPE"
    plan = write_plan(tmp_path, data)
    cli_error(["optimize", plan, "--json"], INPUT_ERROR, "operations[1].tool", "'NOPE'")


# --------------------------------------------------------------------------------------------
# plan files that cannot be read


def test_missing_plan_file(tmp_path: Path) -> None:
    missing = tmp_path / "no-such-plan.toml"
    cli_error(["optimize", missing], INPUT_ERROR, "plan file", str(missing), "no such file")


def test_malformed_toml(tmp_path: Path) -> None:
    plan = tmp_path / "bad.toml"
    plan.write_text('name = "x"\n[machine\nname = "lathe"\n', encoding="utf-8")
    line = cli_error(["optimize", plan], INPUT_ERROR, "plan file", str(plan), "TOML")
    assert "line 2" in line  # where the syntax error is


def test_plan_file_not_utf8(tmp_path: Path) -> None:
    plan = tmp_path / "binary.toml"
    plan.write_bytes(b"\xff\xfe\x00not toml")
    cli_error(["optimize", plan], INPUT_ERROR, "plan file", str(plan))


def test_directory_as_plan_file(tmp_path: Path) -> None:
    cli_error(["optimize", tmp_path], INPUT_ERROR, "plan file", str(tmp_path), "Is a directory")


def test_empty_plan_file(tmp_path: Path) -> None:
    plan = tmp_path / "empty.toml"
    plan.write_text("", encoding="utf-8")
    cli_error(["optimize", plan], INPUT_ERROR, "machine", "required")


def test_missing_file_given_to_predict_plan(tmp_path: Path) -> None:
    missing = tmp_path / "nope.toml"
    cli_error(
        ["predict", "--tool", "CNMG432RN", *POINT, "--plan", missing],
        INPUT_ERROR,
        "plan file",
        str(missing),
    )


# --------------------------------------------------------------------------------------------
# infeasible plans -> exit 3, names the operation, the conflicting limits and what they need

_NEEDS = re.compile(r"force_N <= 50 needs a limit of at least ([0-9.eE+-]+)")


def test_force_limit_no_parameters_can_meet(tmp_path: Path) -> None:
    data = demo()
    data["operations"][0]["limits"]["force_N"] = 50
    line = cli_error(
        ["optimize", write_plan(tmp_path, data)], INFEASIBLE, "rcb: infeasible:", "'rough-od'"
    )
    match = _NEEDS.search(line)
    assert match, line
    needed = float(match.group(1))
    assert needed > 50
    # The value it names is the least limit that works: just above it the plan is feasible,
    # just below it is still infeasible.
    data["operations"][0]["limits"]["force_N"] = needed * 1.01
    code, _, stderr, _ = invoke(["optimize", write_plan(tmp_path, data, "above.toml")])
    assert code == 0, stderr
    data["operations"][0]["limits"]["force_N"] = needed * 0.99
    cli_error(["optimize", write_plan(tmp_path, data, "below.toml")], INFEASIBLE, "force_N")


def test_conflicting_limits_are_named(tmp_path: Path) -> None:
    data = demo()
    data["operations"][0]["limits"] = {"force_N": 1000, "roughness_um": 1.0, "parts_per_edge": 1e4}
    line = cli_error(
        ["optimize", write_plan(tmp_path, data)],
        INFEASIBLE,
        "'rough-od'",
        "roughness_um <= 1 needs a limit of at least",
    )
    # The tool-life limit is named as the engineer wrote it: parts_per_edge and its value.
    match = re.search(r"parts_per_edge >= (\S+) can reach at most (\S+?)[;) ]", line + " ")
    assert match, line
    assert float(match.group(1)) == pytest.approx(1e4, rel=1e-3)
    assert float(match.group(2)) < 1e4
    assert "; " in line  # two limits have to move


def test_parts_per_edge_no_parameters_can_meet(tmp_path: Path) -> None:
    data = demo()
    data["operations"][0]["limits"]["parts_per_edge"] = 1e6
    line = cli_error(["optimize", write_plan(tmp_path, data)], INFEASIBLE, "'rough-od'")
    match = re.search(r"parts_per_edge >= (\S+) can reach at most ([0-9.eE+-]+)", line)
    assert match, line
    assert float(match.group(1)) == pytest.approx(1e6, rel=1e-3)
    reachable = float(match.group(2))
    # The value it names is the most parts an edge can make: a little less is feasible,
    # a little more is not.
    data["operations"][0]["limits"]["parts_per_edge"] = reachable * 0.99
    code, _, stderr, _ = invoke(["optimize", write_plan(tmp_path, data, "below.toml")])
    assert code == 0, stderr
    data["operations"][0]["limits"]["parts_per_edge"] = reachable * 1.01
    cli_error(["optimize", write_plan(tmp_path, data, "above.toml")], INFEASIBLE, "parts_per_edge")


def test_machine_limit_no_parameters_can_meet(tmp_path: Path) -> None:
    data = demo()
    data["machine"]["max_spindle_rpm"] = 1
    cli_error(
        ["optimize", write_plan(tmp_path, data)],
        INFEASIBLE,
        "'rough-od'",
        "spindle_rpm <= 1 needs a limit of at least",
    )


def test_tool_life_band_wider_than_k(tmp_path: Path) -> None:
    data = demo()
    data["operations"][0]["setpoint_rel_uncertainty"] = {"depth_mm": 5.0}
    cli_error(
        ["optimize", write_plan(tmp_path, data)], INFEASIBLE, "'rough-od'", "parts_per_edge >= 10 "
    )


def test_tool_life_band_wider_than_k_names_the_uncertainty(tmp_path: Path) -> None:
    data = demo()
    data["operations"][0]["setpoint_rel_uncertainty"] = {"depth_mm": 5.0}
    cli_error(
        ["optimize", write_plan(tmp_path, data)],
        INFEASIBLE,
        "setpoint_rel_uncertainty",
        "depth_mm",
        "5",
    )


def test_tiny_diameter_in_plan(tmp_path: Path) -> None:
    data = demo()
    data["operations"][0]["workpiece_diameter_mm"] = 1e-320
    cli_error(["optimize", write_plan(tmp_path, data)], INPUT_ERROR, "workpiece_diameter_mm")


# --------------------------------------------------------------------------------------------
# rcb predict

PREDICT_INPUT_ERRORS: list[Any] = [
    pytest.param(
        ["--tool", "CNMG432RN", "--depth-mm", "-2", "--feed-mm-rev", "0.3", "--speed-m-min", "150"],
        ["--depth-mm", "-2"],
        id="negative-depth",
    ),
    pytest.param(
        ["--tool", "CNMG432RN", "--depth-mm", "0", "--feed-mm-rev", "0.3", "--speed-m-min", "150"],
        ["--depth-mm", "0"],
        id="zero-depth",
    ),
    pytest.param(
        ["--tool", "CNMG432RN", "--depth-mm", "nan", "--feed-mm-rev", "0.3", "--speed-m-min", "1"],
        ["--depth-mm", "nan"],
        id="nan-depth",
    ),
    pytest.param(
        ["--tool", "CNMG432RN", "--feed-mm-rev", "0.3", "--speed-m-min", "150"],
        ["--depth-mm", "required"],
        id="missing-depth",
    ),
    pytest.param(
        ["--tool", "NOPE", *POINT],
        ["--tool", "'NOPE'", "CNMG432RN"],
        id="unknown-tool",
    ),
    pytest.param(
        ["--tool", "CNMG432RN", *POINT, "--axial-depth-mm", "2"],
        ["--axial-depth-mm", "2", "turning"],
        id="milling-parameter-on-turning-tool",
    ),
    pytest.param(
        ["--tool", "CNMG432RN", *POINT, "--tool-diameter-mm", "10"],
        ["--tool-diameter-mm", "10", "turning"],
        id="milling-diameter-on-turning-tool",
    ),
    pytest.param(
        ["--tool", "CNMG432RN", *POINT, "--flank-wear-mm", "0"],
        ["--flank-wear-mm", "0"],
        id="zero-flank-wear",
    ),
    pytest.param(
        ["--tool", "CNMG432RN", *POINT, "--rel-uncertainty", "depth_mm"],
        ["--rel-uncertainty", "'depth_mm'", "NAME=VALUE"],
        id="rel-uncertainty-without-value",
    ),
    pytest.param(
        ["--tool", "CNMG432RN", *POINT, "--rel-uncertainty", "depth_mm=abc"],
        ["--rel-uncertainty depth_mm", "'abc'"],
        id="rel-uncertainty-not-a-number",
    ),
    pytest.param(
        ["--tool", "CNMG432RN", *POINT, "--rel-uncertainty", "depth_mm=-0.1"],
        ["--rel-uncertainty depth_mm", "-0.1"],
        id="rel-uncertainty-negative",
    ),
    pytest.param(
        ["--tool", "CNMG432RN", *POINT, "--rel-uncertainty", "depth_mm=inf"],
        ["--rel-uncertainty depth_mm", "inf"],
        id="rel-uncertainty-infinite",
    ),
    pytest.param(
        ["--tool", "CNMG432RN", *POINT, "--rel-uncertainty", "dept_mm=0.1"],
        ["--rel-uncertainty", "'dept_mm'"],
        id="rel-uncertainty-unknown-parameter",
    ),
    pytest.param(
        ["--tool", "CNMG432RN", *POINT, "--flutes", "4"],
        ["--flutes", "4", "turning"],  # "--flute-count" does not contain "--flutes"
        id="flutes-on-turning-tool",
    ),
    pytest.param(
        ["--tool", "CNMG432RN", *POINT, "--diameter-mm", "-5"],
        ["--diameter-mm", "-5"],  # "--workpiece-diameter-mm" does not contain it
        id="negative-diameter",
    ),
    pytest.param(
        ["--tool", "CNMG432RN", *POINT, "--diameter-mm", "5e-324"],
        ["--diameter-mm", "5e-324"],
        id="tiny-diameter",
    ),
]


@pytest.mark.parametrize(("args", "needles"), PREDICT_INPUT_ERRORS)
def test_predict_input_error(args: list[str], needles: list[str]) -> None:
    line = cli_error(["predict", *args], INPUT_ERROR, *needles)
    assert line.startswith("rcb: error: ")


def test_predict_unknown_tool_with_plan(tmp_path: Path) -> None:
    plan = write_plan(tmp_path, demo())
    cli_error(["predict", "--tool", "NOPE", *POINT, "--plan", plan], INPUT_ERROR, "'NOPE'")


def test_predict_inline_tool_from_plan(tmp_path: Path) -> None:
    data = demo()
    _inline_tool({"depth_mm": 0.9, "feed_mm_rev": 0.7})(data)
    plan = write_plan(tmp_path, data)
    code, stdout, stderr, _ = invoke(
        ["predict", "--tool", "MY-INSERT", *POINT, "--plan", plan, "--json"]
    )
    assert code == 0, stderr
    force = json.loads(stdout)["predicted"]["force_N"]["value"]
    assert force == pytest.approx(2000 * 2**0.9 * 0.3**0.7)


@pytest.mark.parametrize(
    ("args", "needles"),
    [
        pytest.param(
            [
                "predict",
                "--tool",
                "CNMG432RN",
                "--depth-mm",
                "abc",
                "--feed-mm-rev",
                "0.3",
                "--speed-m-min",
                "150",
            ],
            ["--depth-mm", "abc"],
            id="depth-not-a-number",
        ),
        pytest.param(["optimize"], ["PLAN.toml"], id="missing-plan-argument"),
    ],
)
def test_usage_errors_one_line(args: list[str], needles: list[str]) -> None:
    cli_error(args, INPUT_ERROR, *needles)


# --------------------------------------------------------------------------------------------
# the installed console script, stdout and stderr on pipes


def test_script_demo_plan_json() -> None:
    code, stdout, stderr = run_rcb(["optimize", DEMO_PLAN, "--json"])
    assert code == 0, stderr
    assert "Traceback" not in stderr
    result = json.loads(stdout)
    assert result["plan"] == "ivester-demo-part"
    names = [op["name"] for op in result["operations"]]
    assert names == [op["name"] for op in _DEMO["operations"]]
    rough = result["operations"][0]
    assert rough["predicted"]["force_N"]["value"] + rough["predicted"]["force_N"]["band"] <= (
        2000 * (1 + 1e-6)
    )
    assert rough["mrr_cm3_min"] == pytest.approx(191, rel=0.01)  # Ivester Table 5 step 1 row R
    assert result["cycle_time_min"] == pytest.approx(
        sum(op["time_min"] for op in result["operations"])
    )


def test_script_infeasible(tmp_path: Path) -> None:
    data = demo()
    data["operations"][0]["limits"]["force_N"] = 50
    line = one_line(
        *run_rcb(["optimize", write_plan(tmp_path, data)]), INFEASIBLE, "'rough-od'", "force_N"
    )
    assert _NEEDS.search(line), line


def test_script_inverted_bounds(tmp_path: Path) -> None:
    data = demo()
    data["operations"][0]["bounds"]["depth_mm"] = [3.0, 0.5]
    one_line(
        *run_rcb(["optimize", write_plan(tmp_path, data)]),
        INPUT_ERROR,
        "operations[0].bounds.depth_mm",
        "[3.0, 0.5]",
    )


def test_script_missing_file(tmp_path: Path) -> None:
    missing = tmp_path / "missing.toml"
    one_line(*run_rcb(["optimize", missing]), INPUT_ERROR, str(missing))


def test_script_predict_unknown_tool() -> None:
    one_line(*run_rcb(["predict", "--tool", "NOPE", *POINT]), INPUT_ERROR, "--tool", "'NOPE'")


def test_script_long_message_not_wrapped_on_narrow_terminal(tmp_path: Path) -> None:
    """The unknown-field message lists every allowed field: far wider than 40 columns."""
    data = demo()
    data["operations"][0]["limits"]["forse_N"] = 100
    line = one_line(
        *run_rcb(["optimize", write_plan(tmp_path, data)], columns=40),
        INPUT_ERROR,
        "operations[0].limits.forse_N",
        "100",
        "parts_per_edge",
    )
    assert len(line) > 120


@pytest.mark.parametrize("group", [[], ["keys"], ["milling"], ["db"]])
def test_a_group_without_a_command_prints_its_help_once(group):
    proc = subprocess.run([_rcb(), *group], capture_output=True, text=True, timeout=60, check=False)
    assert proc.returncode == 2
    assert (proc.stdout + proc.stderr).count("Usage:") == 1
    assert "Traceback" not in proc.stderr
