"""``rcb predict`` and usage errors at the command line, and the installed ``rcb`` console script
with stdout and stderr on pipes: a non-zero exit and one line naming field and value.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path
from typing import Any

import pytest
from cli_errors_support import (
    _DEMO,
    _NEEDS,
    DEMO_PLAN,
    INFEASIBLE,
    INPUT_ERROR,
    POINT,
    _inline_tool,
    _rcb,
    cli_error,
    demo,
    invoke,
    one_line,
    run_rcb,
    write_plan,
)

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
