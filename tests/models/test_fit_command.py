"""``rcb fit`` on the roughness set: JSON and table output, row filters, fixed exponents, a tool
written as TOML that reads back; its errors exit 2 with one line naming field and value, no
traceback, nothing written.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any

import pytest
from fit_support import (
    INPUT_ERROR,
    ROUGHNESS_CSV,
    TURNING_COLUMNS,
    VAR_ARGS,
    ra,
    roughness,
    run,
    turning_fit,
)
from typer.testing import CliRunner

from api.cli.fit_tool import tool_table, tool_toml
from models.errors import InputError
from models.tool import tool_from_mapping
from supervisor.inputs.plan import plan_from_mapping

# --------------------------------------------------------------------------------------------
# (g) the command line


def test_json_output_is_the_fit() -> None:
    code, out, err = run([ROUGHNESS_CSV, "--response=Ra", *VAR_ARGS, "--json"])
    assert code == 0, err
    data = json.loads(out)
    direct = turning_fit(roughness())
    for key in ("K", "dK", "s", "r2"):
        assert data[key] == pytest.approx(getattr(direct, key), rel=1e-12)
    assert data["exponents"] == pytest.approx(dict(direct.exponents), rel=1e-12)
    assert data["stderr"] == pytest.approx(dict(direct.stderr), rel=1e-12)
    assert set(data["stderr"]) == {"ln_K", *TURNING_COLUMNS}
    assert data["n"] == 2448 and data["coverage"] == 1.0
    assert data["band"] == "range" and data["k"] is None
    assert data["columns"] == TURNING_COLUMNS and data["where"] == []
    assert data["source"] == "fit of aisi12l14_turning_roughness.csv (2448 points, all rows)"


def test_where_filters_rows_by_text() -> None:
    code, out, err = run(
        [ROUGHNESS_CSV, "--response=Ra", *VAR_ARGS, "--where=VB=Worn", "--band=2s", "--json"]
    )
    assert code == 0, err
    data = json.loads(out)
    worn = turning_fit(ra("Worn"), band="2s")
    assert data["n"] == 1224 and data["coverage"] == pytest.approx(0.9763, abs=1e-4)
    assert data["K"] == pytest.approx(worn.K, rel=1e-12)
    # several --where are ANDed; text comparison on the cell ("D30" in the 5th column)
    code, out, _ = run(
        [ROUGHNESS_CSV, "--response=Ra", *VAR_ARGS, "--where=VB=New", "--where=P=Chuck", "--json"]
    )
    assert code == 0 and json.loads(out)["n"] == 408


def test_fixed_exponent_from_the_cli() -> None:
    code, out, err = run(
        [ROUGHNESS_CSV, "--response=Ra", "--var=depth_mm=d", "--var=feed_mm_rev=f",
         "--fix=speed_m_min=0", "--where=VB=New", "--json"]
    )  # fmt: skip
    assert code == 0, err
    data = json.loads(out)
    assert data["fixed"] == {"speed_m_min": 0.0} and data["exponents"]["speed_m_min"] == 0.0
    assert set(data["stderr"]) == {"ln_K", "depth_mm", "feed_mm_rev"}


def test_table_output() -> None:
    code, out, err = run([ROUGHNESS_CSV, "--response=Ra", *VAR_ARGS, "--quantity=roughness_um"])
    assert code == 0, err
    for text in ("roughness_um", "depth_mm", "ΔK (range)", "coverage", "2448"):
        assert text in out


def test_write_tool_round_trip(tmp_path: Path) -> None:
    out_file = tmp_path / "fitted.toml"
    code, out, err = run(
        [ROUGHNESS_CSV, "--response=Ra", *VAR_ARGS, "--where=VB=New", "--band=2s",
         "--quantity=roughness_um", "--tool-name=P35-12L14-NEW", f"--write-tool={out_file}",
         "--json"]
    )  # fmt: skip
    assert code == 0, err
    assert "wrote tool P35-12L14-NEW" in err
    fitted = json.loads(out)
    assert fitted["written"] == str(out_file)
    with out_file.open("rb") as file:
        written = tomllib.load(file)
    assert len(written["tools"]) == 1
    entry = written["tools"][0]
    assert entry["source"] == "fit of aisi12l14_turning_roughness.csv (1224 points, VB=New)"
    tool = tool_from_mapping(entry, "tools[0]")
    model = tool.models["roughness_um"]
    assert (tool.name, tool.process) == ("P35-12L14-NEW", "turning")
    assert (model.K, model.dK) == (fitted["K"], fitted["dK"])  # exact: floats written by repr
    assert dict(model.exponents) == fitted["exponents"]
    # the exponents' standard errors go with the model (the learn strategy's prior spread)
    assert dict(model.exponent_stderr) == {n: fitted["stderr"][n] for n in model.exponents}
    assert "n = 1224" in model.reference and "band = 2·s" in model.reference

    plan = plan_from_mapping(
        {
            "name": "fit-round-trip",
            "machine": {"name": "lathe", "max_spindle_rpm": 4000},
            "tools": written["tools"],
            "operations": [
                {
                    "name": "finish",
                    "tool": "P35-12L14-NEW",
                    "workpiece_diameter_mm": 30,
                    "volume_mm3": 5000,
                    "limits": {"roughness_um": 6.0},
                    "bounds": {
                        "depth_mm": [0.7, 1.2],
                        "feed_mm_rev": [0.08, 0.12],
                        "speed_m_min": [220, 340],
                    },
                }
            ],
        }
    )
    assert plan.tools["P35-12L14-NEW"].models["roughness_um"] == model
    point = {"depth_mm": 0.95, "feed_mm_rev": 0.1, "speed_m_min": 280}
    direct = turning_fit(ra("New"), band="2s").to_model("roughness_um")
    assert model.predict(point).value == pytest.approx(direct.predict(point).value, rel=1e-12)
    assert model.predict(point).band == pytest.approx(direct.predict(point).band, rel=1e-12)


def test_tool_toml_escapes_strings() -> None:
    result = turning_fit(ra("New"))
    awkward = 'P35 "new" \\ 12L14\tµm\x7f\n'
    name = 'P35 "new" \\ 12L14 µm'  # a name holds no control character (models.fields.identity)
    table = tool_table(result, name, "turning", "roughness_um", awkward, "ref")
    entry = tomllib.loads(tool_toml(table))["tools"][0]
    assert entry["name"] == name and entry["models"]["roughness_um"]["source"] == awkward
    assert entry["models"]["roughness_um"]["K"] == result.K
    with pytest.raises(InputError, match=r"^--write-tool.name = .*control characters \(U\+0009"):
        tool_toml(tool_table(result, awkward, "turning", "roughness_um", awkward, "ref"))


# errors: exit 2, one line "rcb: error: FIELD = VALUE: reason", no traceback, nothing written

BAD_CSV = """Vc,f,d,VB,Ra
220,0.08,0.7,New,3.8
340,0.08,0.7,New,4.1
220,0.12,0.7,New,abc
340,0.12,0.7,New,-1
220,0.08,1.2,New,
340,0.08,1.2,Worn,nan
220,0.12,1.2,New,2.5
340,0.12,1.2,New,2.2
"""


def _case(case_id: str, args: list[str], *needles: str) -> Any:
    return pytest.param(args, list(needles), id=case_id)


R = "--response=Ra"
CLI_ERRORS: list[Any] = [
    _case("missing-file", ["{missing}", R], "data file", "no such file"),
    _case("missing-response", ["{good}", "--response=Rx"], "--response = 'Rx'", "columns: Number"),
    _case("missing-var-column", ["{good}", R, "--var=depth_mm=depth"],
          "--var depth_mm = 'depth'", "no such column", "columns:"),
    _case("unknown-variable", ["{good}", R, "--var=depth=d"],
          "--var = 'depth=d'", "not a turning variable", "depth_mm"),
    _case("turning-variable-for-milling", ["{good}", R, "--process=milling", "--var=depth_mm=d"],
          "--var = 'depth_mm=d'", "not a milling variable", "axial_depth_mm"),
    _case("unknown-process", ["{good}", R, "--process=grinding"], "--process", "grinding"),
    _case("not-a-number", ["{bad}", R, "--var=speed_m_min=Vc"],
          "Ra[row 3] = 'abc'", "must be a number"),
    _case("not-a-number-after-filter", ["{bad}", R, "--var=speed_m_min=Vc", "--where=f=0.12"],
          "Ra[row 3] = 'abc'"),
    _case("empty-cell", ["{bad}", R, "--var=speed_m_min=Vc", "--where=d=1.2"],
          "Ra[row 5] = ''", "missing value"),
    _case("too-few-after-filter",
          ["{bad}", R, "--var=speed_m_min=Vc", "--where=Ra=-1", "--fix=speed_m_min=0"],
          "--where = 'Ra=-1'", "leaves 1 row for 1 parameter", "need at least 2"),
    _case("too-few-after-two-filters",
          ["{bad}", "--response=Vc", "--var=speed_m_min=f", "--where=Ra=-1", "--where=VB=New"],
          "--where = 'Ra=-1, VB=New'", "leaves 1 row for"),
    _case("too-few-rows", ["{bad}", R, "--var=feed_mm_rev=f", "--where=VB=Worn"],
          "--where = 'VB=Worn'", "leaves 1 row for 2 parameters"),
    _case("negative", ["{negative}", R, "--var=feed_mm_rev=f"],
          "Ra[row 4] = '-1'", "greater than 0"),
    _case("nan", ["{nan}", R, "--var=feed_mm_rev=f"], "Ra[row 6] = 'nan'", "finite"),
    _case("where-no-match", ["{good}", R, "--where=VB=Old"],
          "--where = 'VB=Old'", "matches no row", "'New', 'Worn'"),
    _case("where-malformed", ["{good}", R, "--where=VB"], "--where = 'VB'", "COLUMN=TEXT"),
    _case("where-unknown-column", ["{good}", R, "--where=Tool=A"],
          "--where = 'Tool=A'", "no column Tool"),
    _case("constant-column", ["{good}", R, "--var=depth_mm=d", "--where=Number=1"],
          "d = 0.7", "constant column", "depth_mm"),
    _case("same-column", ["{good}", R, "--var=depth_mm=d", "--var=feed_mm_rev=d"],
          "--var feed_mm_rev = 'd'", "already used by --var depth_mm"),
    _case("response-as-variable", ["{good}", R, "--var=depth_mm=Ra"],
          "--var depth_mm = 'Ra'", "already used by --response"),
    _case("unknown-band", ["{good}", R, "--band=3s"], "--band = '3s'", "range, 2s"),
    _case("bad-k", ["{good}", R, "--band=2s", "--k=-1"], "--k = -1.0"),
    _case("k-without-2s", ["{good}", R, "--k=3"], "--k = 3.0", "--band 2s only"),
    _case("fix-without-column", ["{good}", R, "--fix=depth_mm=0.5"],
          "--fix depth_mm = 0.5", "add --var depth_mm=COLUMN"),
    _case("fix-not-a-number", ["{good}", R, "--var=depth_mm=d", "--fix=depth_mm=x"],
          "--fix depth_mm = 'x'", "must be a number"),
    _case("unknown-quantity", ["{good}", R, "--quantity=finish"],
          "--quantity = 'finish'", "roughness_um"),
]  # fmt: skip


NEGATIVE_CSV = "Ra,f\n3.8,0.08\n4.1,0.10\n2.5,0.12\n-1,0.08\n2.2,0.10\n"
NAN_CSV = "Ra,f\n3.8,0.08\n4.1,0.10\n2.5,0.12\n2.0,0.08\n2.2,0.10\nnan,0.12\n"


def _paths(tmp_path: Path) -> dict[str, Path]:
    paths = {"good": ROUGHNESS_CSV, "missing": tmp_path / "no-such.csv"}
    for name, text in (("bad", BAD_CSV), ("negative", NEGATIVE_CSV), ("nan", NAN_CSV)):
        paths[name] = tmp_path / f"{name}.csv"
        paths[name].write_text(text, encoding="utf-8")
    return paths


def _one_line(code: int, out: str, err: str, *needles: str) -> str:
    assert "Traceback" not in out + err, err
    assert code == INPUT_ERROR, (code, out, err)
    assert out == ""
    line = err.removesuffix("\n")
    assert line.startswith("rcb: error: ") and "\n" not in line, err
    for needle in needles:
        assert needle in line, f"{needle!r} not in {line!r}"
    return line


@pytest.mark.parametrize(("args", "needles"), CLI_ERRORS)
def test_cli_errors(tmp_path: Path, args: list[str], needles: list[str]) -> None:
    paths = _paths(tmp_path)
    out_file = tmp_path / "out.toml"
    full = [a.format(**{k: str(v) for k, v in paths.items()}) for a in args]
    full += ["--quantity=roughness_um", "--tool-name=T", f"--write-tool={out_file}"]
    if any(a.startswith("--quantity") for a in args):
        full = [a for a in full if a != "--quantity=roughness_um"]
    _one_line(*run(full), *needles)
    assert not out_file.exists()
    assert [p.name for p in tmp_path.iterdir() if p.suffix == ".tmp"] == []


def test_write_tool_errors_leave_an_existing_file_alone(tmp_path: Path) -> None:
    out_file = tmp_path / "tool.toml"
    out_file.write_text("# mine\n", encoding="utf-8")
    args = [ROUGHNESS_CSV, "--response=Ra", *VAR_ARGS, "--quantity=roughness_um"]
    _one_line(*run([*args, "--where=VB=Old", "--tool-name=T", f"--write-tool={out_file}"]))
    required = "required with --write-tool"
    _one_line(*run([*args, f"--write-tool={out_file}"]), f"--tool-name: {required}")
    _one_line(
        *run([ROUGHNESS_CSV, "--response=Ra", "--tool-name=T", f"--write-tool={out_file}"]),
        f"--quantity: {required}",
    )
    missing_dir = tmp_path / "no-such-dir" / "tool.toml"
    _one_line(*run([*args, "--tool-name=T", f"--write-tool={missing_dir}"]), "does not exist")
    assert out_file.read_text(encoding="utf-8") == "# mine\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tool.toml"]


@pytest.mark.parametrize(
    ("text", "needles"),
    [
        ("", ["data file", "empty"]),
        ("Ra,f\n", ["data file", "no rows"]),
        ('Ra,f\n1,2\n3,4,5,6\n"', ["data file", "not a CSV table"]),
    ],
    ids=["empty", "header-only", "ragged"],
)
def test_unreadable_csv(tmp_path: Path, text: str, needles: list[str]) -> None:
    csv = tmp_path / "data.csv"
    csv.write_text(text, encoding="utf-8")
    _one_line(*run([csv, "--response=Ra"]), *needles)


def test_not_utf8(tmp_path: Path) -> None:
    csv = tmp_path / "data.csv"
    csv.write_bytes(b"Ra,f\n1,2\n\xff\xfe,3\n")
    _one_line(*run([csv, "--response=Ra"]), "data file", "UTF-8")


def test_registered_in_rcb() -> None:
    """The real ``rcb fit`` gives the same one-line errors."""
    from api.cli.main import app

    result = CliRunner().invoke(app, ["fit", str(ROUGHNESS_CSV), "--response=Rx"])
    _one_line(result.exit_code, result.stdout, result.stderr, "--response = 'Rx'")
