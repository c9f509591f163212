"""Plan files ``rcb optimize`` cannot use: a file that cannot be read is bad input (exit 2), naming
the file; an infeasible plan exits 3, naming the operation, the conflicting limits and the least
limit that works.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from cli_errors_support import (
    _NEEDS,
    INFEASIBLE,
    INPUT_ERROR,
    POINT,
    cli_error,
    demo,
    invoke,
    write_plan,
)

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
