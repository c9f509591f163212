"""Issue 29 point 8: one set of bounds (``models.bounds``), refused alike by the CLI and REST.

Each case sends one input past one bound of :data:`models.bounds.BOUNDS` to both surfaces: a
plan to ``rcb optimize PLAN.toml`` (exit 2, one line naming the field) and to ``POST /plans``
(422 or 413 problem+json naming the field); a part report to ``POST /plans/{id}/parts`` and to
the domain reader every other caller uses (no ``rcb`` command reads a part report); ``rcb fit``'s
CSV to ``rcb fit`` (REST fits nothing). Values are derived from the bounds, so a changed bound
is tested where it is; a new bound without a case fails :func:`test_every_bound_has_a_case`.
The tester's reproductions: a 10 000-operation plan (147 s in ``rcb optimize``) and a 1e308
cell in ``rcb fit`` that wrote a tool with dK = 1.7e87.
"""

from __future__ import annotations

import copy
import itertools
import json
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from cli_errors_support import INPUT_ERROR, cli_error, dumps, one_line, run_rcb

from api.rest.schemas.parts import parse_report
from models import bounds
from models.errors import InputError

from conftest import DEMO_PLAN, ROOT, report_at

DEMO: dict[str, Any] = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
MILLING: dict[str, Any] = tomllib.loads(
    (ROOT / "examples" / "tai_constant_load_part.toml").read_text(encoding="utf-8")
)
_keys = itertools.count()

Edit = Callable[[dict[str, Any]], None]


def _plan(edit: Edit, base: dict[str, Any] = DEMO) -> dict[str, Any]:
    plan = copy.deepcopy(base)
    edit(plan)
    return plan


def _set(*path: str | int, value: Any) -> Edit:
    def edit(data: dict[str, Any]) -> None:
        *head, last = path
        target: Any = data
        for key in head:
            target = target[key]
        target[last] = value

    return edit


def _inline_tool(**model: Any) -> Edit:
    """An inline copy of the demo's force model (Ivester & Heigel Table 2) with ``model`` set."""

    def edit(data: dict[str, Any]) -> None:
        force = {"K": 1867.0, "dK": 100.0, "exponents": {"depth_mm": 0.9, "feed_mm_rev": 0.7}}
        tool = {"name": "T-inline", "process": "turning", "models": {"force_N": force}}
        force.update(model)
        data["tools"] = [tool]
        for op in data["operations"]:
            op["tool"] = "T-inline"
            op["limits"] = {"force_N": op["limits"]["force_N"]}

    return edit


def _operations(count: int) -> Edit:
    def edit(data: dict[str, Any]) -> None:
        first = data["operations"][0]
        data["operations"] = [{**first, "name": f"op-{i}"} for i in range(count)]

    return edit


def _tools(count: int) -> Edit:
    def edit(data: dict[str, Any]) -> None:
        data["tools"] = [
            {"name": f"T{i}", "process": "turning", "models": {"force_N": {"K": 1000.0}}}
            for i in range(count)
        ]

    return edit


def _calibrations(count: int) -> Edit:
    def edit(data: dict[str, Any]) -> None:
        data["machine"]["calibrations"] = {f"c{i}": {"kind": "x"} for i in range(count)}

    return edit


def _constant_load_keys(count: int) -> Edit:
    def edit(data: dict[str, Any]) -> None:
        data["operations"][0]["constant_load"] = {f"k{i}": 1.0 for i in range(count)}

    return edit


#: (bound, id, plan, the field the CLI names, the field REST names): one input past one bound.
PLAN_CASES: list[tuple[str, str, dict[str, Any], str, str]] = [
    ("LARGEST", "limit-over", _plan(_set("operations", 0, "limits", "force_N",
     value=bounds.LARGEST * 10)), "operations[0].limits.force_N", ""),
    ("LARGEST", "tool-dK-1.7e87", _plan(_inline_tool(dK=1.7e87)),
     "tools[0].models.force_N.dK", ""),
    ("LARGEST", "machine-negative", _plan(_set("machine", "max_power_kW",
     value=-bounds.LARGEST * 10)), "machine.max_power_kW", ""),
    ("SMALLEST_POSITIVE", "volume-under", _plan(_set("operations", 0, "volume_mm3",
     value=bounds.SMALLEST_POSITIVE / 10)), "operations[0].volume_mm3", ""),
    ("LARGEST_EXPONENT", "exponent-over", _plan(_inline_tool(exponents={
     "depth_mm": bounds.LARGEST_EXPONENT + 1})), "tools[0].models.force_N.exponents.depth_mm",
     ""),
    ("MAX_FLUTES", "flutes-over", _plan(_set("operations", 0, "flute_count",
     value=bounds.MAX_FLUTES + 1), MILLING), "operations[0].flute_count", ""),
    ("MAX_OPERATIONS", "operations-over", _plan(_operations(bounds.MAX_OPERATIONS + 1)),
     "operations", ""),
    ("MAX_TOOLS", "tools-over", _plan(_tools(bounds.MAX_TOOLS + 1)), "tools", ""),
    ("MAX_CALIBRATIONS", "calibrations-over",
     _plan(_calibrations(bounds.MAX_CALIBRATIONS + 1), MILLING), "machine.calibrations", ""),
    # the plan reader refuses the first unknown key, in either surface (issue 31: REST's
    # schema, which counted the keys, no longer reads a plan)
    ("MAX_TABLE_KEYS", "constant-load-keys-over",
     _plan(_constant_load_keys(bounds.MAX_TABLE_KEYS + 1), MILLING),
     "operations[0].constant_load.k0", ""),
    ("MAX_IDENTITY", "plan-name-over", _plan(_set("name", value="P" * (bounds.MAX_IDENTITY + 1))),
     "name", ""),
    ("MAX_IDENTITY", "machine-name-over", _plan(_set("machine", "name",
     value="M" * (bounds.MAX_IDENTITY + 1))), "machine.name", ""),
    ("MAX_TEXT", "description-over", _plan(_set("description",
     value="d" * (bounds.MAX_TEXT + 1))), "description", ""),
    # the tester's 10 000-operation plan: over 1 MiB as a file and as a body
    ("MAX_DOCUMENT_BYTES", "10000-operations", _plan(_operations(10_000)), "plan file", "body"),
]  # fmt: skip


def _plan_ids() -> list[str]:
    return [case[1] for case in PLAN_CASES]


@pytest.mark.parametrize(("bound", "case", "plan", "cli_field", "rest_field"), PLAN_CASES,
                         ids=_plan_ids())  # fmt: skip
def test_a_plan_past_a_bound_is_refused_by_rcb_optimize_naming_the_field(
    tmp_path: Path, bound: str, case: str, plan: dict[str, Any], cli_field: str, rest_field: str
) -> None:
    path = tmp_path / "plan.toml"
    path.write_text(dumps(plan), encoding="utf-8")
    line = cli_error(["optimize", str(path)], INPUT_ERROR, f"rcb: error: {cli_field} = ")
    if bound in ("MAX_OPERATIONS", "MAX_TOOLS", "MAX_CALIBRATIONS"):
        assert f"= {bounds.BOUNDS[_index(bound)].value + 1}: at most" in line  # the count


@pytest.mark.parametrize(("bound", "case", "plan", "cli_field", "rest_field"), PLAN_CASES,
                         ids=_plan_ids())  # fmt: skip
def test_the_same_plan_is_refused_by_rest_naming_the_field(
    sqlite_server, bound: str, case: str, plan: dict[str, Any], cli_field: str, rest_field: str
) -> None:
    with sqlite_server.client("engineer") as c:
        r = c.post("/plans", json=plan)
    assert r.status_code == (413 if bound == "MAX_DOCUMENT_BYTES" else 422), r.text
    assert r.headers["content-type"] == "application/problem+json"
    assert r.json()["field"] == (rest_field or cli_field)


def _index(name: str) -> int:
    return next(i for i, b in enumerate(bounds.BOUNDS) if b.name == name)


def test_a_10000_operation_plan_is_refused_by_count_before_anything_is_read(
    tmp_path: Path,
) -> None:
    # under 1 MiB (the operations hold a name only): the count refuses it, naming field and count
    plan = {**copy.deepcopy(DEMO), "operations": [{"name": f"o{i}"} for i in range(10_000)]}
    path = tmp_path / "plan.toml"
    path.write_text(dumps(plan), encoding="utf-8")
    assert path.stat().st_size < bounds.MAX_DOCUMENT_BYTES
    code, stdout, stderr = run_rcb(["optimize", str(path)])
    line = one_line(code, stdout, stderr, INPUT_ERROR)
    assert line == "rcb: error: operations = 10000: at most 100 operations in a plan"


def test_the_10000_operation_plan_is_refused_by_rest_too(sqlite_server) -> None:
    plan = {**copy.deepcopy(DEMO), "operations": [{"name": f"o{i}"} for i in range(10_000)]}
    with sqlite_server.client("engineer") as c:
        r = c.post("/plans", json=plan)
    assert r.status_code == 422, r.text
    assert r.json()["field"] == "operations"


# --------------------------------------------------------------------------------------------
# part reports: REST and the domain reader (the collector and every caller but REST)

_REPORT_EDITS: list[tuple[str, str, Callable[[dict[str, Any]], None], str]] = [
    ("SMALLEST_MEASURED", "value-under", _set("operations", 0, "measurements", "force_N",
     "value", value=bounds.SMALLEST_MEASURED / 10), "operations[0].measurements.force_N.value"),
    ("LARGEST", "value-over", _set("operations", 0, "measurements", "force_N", "value",
     value=bounds.LARGEST * 10), "operations[0].measurements.force_N.value"),
    ("MAX_EDGE_PARTS", "edge-parts-over", _set("operations", 0, "edge_parts",
     value=bounds.MAX_EDGE_PARTS + 1), "operations[0].edge_parts"),
    ("LARGEST_WHOLE", "version-over", _set("setpoint_version", value=bounds.LARGEST_WHOLE + 1),
     "setpoint_version"),
    ("MAX_IDENTITY", "serial-over", _set("serial", value="S" * (bounds.MAX_IDENTITY + 1)),
     "serial"),
]  # fmt: skip


def _report_operations(count: int) -> Callable[[dict[str, Any]], None]:
    def edit(report: dict[str, Any]) -> None:
        first = report["operations"][0]
        report["operations"] = [{**first, "name": f"op-{i}"} for i in range(count)]

    return edit


REPORT_CASES = [
    *_REPORT_EDITS,
    ("MAX_OPERATIONS", "operations-over", _report_operations(bounds.MAX_OPERATIONS + 1),
     "operations"),
]  # fmt: skip

#: A report at the demo plan's first setpoints, without the REST round trip (the reader only
#: checks the report's own values).
_SETPOINTS = {
    "setpoint_version": 1,
    "operations": [
        {"name": op["name"], "predicted": {"force_N": {"value": 1000.0}, "roughness_um": {
            "value": 2.0}}}
        for op in DEMO["operations"]
    ],
}  # fmt: skip


@pytest.mark.parametrize(("bound", "case", "edit", "field"), REPORT_CASES,
                         ids=[c[1] for c in REPORT_CASES])  # fmt: skip
def test_a_report_past_a_bound_is_refused_by_the_domain_reader(bound, case, edit, field) -> None:
    report = report_at("SN-1", _SETPOINTS)
    edit(report)
    with pytest.raises(InputError) as err:
        parse_report(report)
    assert err.value.field == field


@pytest.fixture(scope="module")
def demo_plan(sqlite_server) -> dict[str, Any]:
    with sqlite_server.client("engineer") as c:
        r = c.post("/plans", json={**DEMO, "name": "bounds"})
        assert r.status_code == 201, r.text
        return r.json()


@pytest.mark.parametrize(("bound", "case", "edit", "field"), REPORT_CASES,
                         ids=[c[1] for c in REPORT_CASES])  # fmt: skip
def test_the_same_report_is_refused_by_rest(sqlite_server, demo_plan, bound, case, edit, field):
    report = report_at(f"SN-{next(_keys)}", demo_plan)
    edit(report)
    headers = {"Idempotency-Key": f"bounds-{next(_keys)}"}
    with sqlite_server.client("mes") as c:
        r = c.post(f"/plans/{demo_plan['id']}/parts", json=report, headers=headers)
    assert r.status_code == 422, r.text
    assert r.headers["content-type"] == "application/problem+json"
    assert r.json()["field"] == field


# --------------------------------------------------------------------------------------------
# rcb fit: its CSV file (REST fits nothing)

FIT = ["--response=Fc", "--var=feed_mm_rev=f", "--quantity=force_N"]


def _csv(tmp_path: Path, rows: list[tuple[str, str]]) -> Path:
    path = tmp_path / "cuts.csv"
    path.write_text("f,Fc\n" + "".join(f"{f},{y}\n" for f, y in rows), encoding="utf-8")
    return path


def test_a_1e308_cell_is_refused_naming_row_and_column(tmp_path: Path) -> None:
    data = _csv(tmp_path, [("0.1", "500"), ("0.2", "1e308"), ("0.3", "1300"), ("0.4", "1600")])
    tool = tmp_path / "tool.toml"
    line = cli_error(
        ["fit", str(data), *FIT, "--tool-name=T", f"--write-tool={tool}"],
        INPUT_ERROR,
        "rcb: error: Fc[row 2] = '1e308': must be within ±1e+12",
    )
    assert line
    assert not tool.exists()


def test_a_fitted_tool_past_the_bound_is_not_written(tmp_path: Path) -> None:
    # every cell within 1e12, but K (Y at f = 1) extrapolates past it: F ≈ 1e15 · f^-1
    rows = [(f"{f:g}", f"{1e15 / f * s:.6g}") for f, s in
            ((1e6, 1.0), (2e6, 1.1), (4e6, 0.9), (8e6, 1.05))]  # fmt: skip
    tool = tmp_path / "tool.toml"
    cli_error(
        ["fit", str(_csv(tmp_path, rows)), *FIT, "--tool-name=T", f"--write-tool={tool}"],
        INPUT_ERROR,
        "--write-tool.models.force_N.K = ",
        "must be within ±1e+12",
    )
    assert not tool.exists()


def test_a_csv_over_its_rows_is_refused(tmp_path: Path) -> None:
    rows = [("0.1", "500")] * (bounds.MAX_CSV_ROWS + 1)
    cli_error(["fit", str(_csv(tmp_path, rows)), *FIT], INPUT_ERROR, "data file = ", "rows")


def test_a_csv_over_its_bytes_is_refused_before_it_is_read(tmp_path: Path) -> None:
    path = tmp_path / "cuts.csv"
    with path.open("wb") as file:
        file.write(b"f,Fc\n")
        file.truncate(bounds.MAX_CSV_BYTES + 1)  # sparse: no 16 MiB written
    cli_error(["fit", str(path), *FIT], INPUT_ERROR, "data file = ", "larger than")


FIT_BOUNDS = {"LARGEST", "MAX_CSV_ROWS", "MAX_CSV_BYTES"}
#: A file of learned models: tests/db/test_models_file_size.py (over it, and export under it).
MODELS_BOUNDS = {"MAX_MODELS_BYTES"}


# --------------------------------------------------------------------------------------------
# the table itself


@pytest.mark.parametrize("bound", bounds.BOUNDS, ids=[b.name for b in bounds.BOUNDS])
def test_every_bound_has_a_case(bound: bounds.Bound) -> None:
    assert getattr(bounds, bound.name) == bound.value
    tested = {c[0] for c in PLAN_CASES} | {c[0] for c in REPORT_CASES} | FIT_BOUNDS
    tested |= MODELS_BOUNDS
    assert bound.name in tested, f"{bound.name}: add a case sent to both surfaces"


def test_the_rest_schema_publishes_the_same_bounds() -> None:
    from api.rest.schemas.plans import PlanIn

    schema = json.dumps(PlanIn.model_json_schema())
    assert f'"maxItems": {bounds.MAX_OPERATIONS}' in schema
    assert f'"maxLength": {bounds.MAX_IDENTITY}' in schema
    assert '"maximum": 1000000000000.0' in schema
