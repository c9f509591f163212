"""Bad input at the ``rcb`` command line: a non-zero exit and one line naming field and value.

Requirement: limits no parameters can meet, inverted bounds, negative or zero limits, unknown
tools or quantities, malformed or missing files give exit code != 0 and a one-line message
naming the offending field/quantity and value, with no traceback; infeasibility says which
limits conflict. Exit codes (``api/cli/main.py``): 2 bad input, 3 infeasible, 4 solver failure.

Most cases run in-process with ``typer.testing.CliRunner`` (click >= 8.2 always keeps stderr
apart in ``result.stderr``); a few run the installed ``rcb`` console script as a subprocess.
Plan files are derived from ``examples/ivester_demo_part.toml``.

Here the plan files whose input is bad (exit 2); files that cannot be read and infeasible plans
in test_cli_errors_unsolvable.py, rcb predict and the installed script in
test_cli_errors_predict.py; the helpers in tests/cli_errors_support.py.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import pytest
from cli_errors_support import INPUT_ERROR, Mutation, _inline_tool, cli_error, demo, write_plan


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
        ["operations[3].unknown = true:"],  # as the file spells it (was Python's True)
        id="unknown-operation-field",
    ),
    pytest.param(
        _pop("operations[0].bounds.feed_mm_rev"),
        ["operations[0].bounds.feed_mm_rev: required"],  # no value: not "= None"
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
        ["rcb: error: machine: required"],  # no value: not "= None"
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
