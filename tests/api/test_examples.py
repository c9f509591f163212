"""The example files ship with the package: ``rcb demo`` from any directory, ``rcb examples``.

The real ``rcb`` runs as a subprocess in a temporary directory (no ``examples/`` below it), so
the plans can only come from the installed package data.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from conftest import ROOT

EXAMPLES = ROOT / "examples"
PACKAGED = ROOT / "api" / "cli" / "example_files"
NAMES = sorted(p.stem for p in EXAMPLES.glob("*.toml"))


def _rcb() -> str:
    script = Path(sys.executable).parent / "rcb"
    if not script.is_file():
        pytest.skip("the rcb console script is not installed")
    return str(script)


def rcb(cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "COLUMNS": "80"}
    return subprocess.run(
        [_rcb(), *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=300
    )


def _operations(name: str) -> list[str]:
    plan = tomllib.loads((EXAMPLES / f"{name}.toml").read_text(encoding="utf-8"))
    return [op["name"] for op in plan["operations"]]


def test_one_copy_of_each_example_is_packaged():
    assert NAMES == [
        "borangiu_domain",
        "cam_relief_part",
        "ivester_demo_part",
        "milling_demo_part",
        "milling_passes_part",
        "tai_constant_load_part",
        "turning_passes_part",
        "virtual_lathe_part",
    ]
    assert sorted(p.stem for p in PACKAGED.glob("*.toml")) == NAMES
    for name in NAMES:  # the packaged file is the repository's, not a second copy
        assert (PACKAGED / f"{name}.toml").resolve() == (EXAMPLES / f"{name}.toml").resolve()
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert "example_files/*.toml" in pyproject["tool"]["setuptools"]["package-data"]["api.cli"]


@pytest.mark.parametrize(
    ("args", "example"),
    [([], "ivester_demo_part"), (["--milling"], "milling_demo_part")],
)
def test_demo_runs_from_any_directory(tmp_path, args, example):
    done = rcb(tmp_path, "demo", "--parts", "2", *args, "--json")
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert [op["name"] for op in result["operations"]] == _operations(example)
    assert result["parts"] == 2
    # and as tables (the default output), still from the temporary directory
    table = rcb(tmp_path, "demo", "--parts", "2", *args)
    assert table.returncode == 0, table.stderr
    assert all(name in table.stdout for name in _operations(example))


def test_plan_option_still_overrides(tmp_path):
    done = rcb(tmp_path, "demo", "--parts", "1", "--plan", str(EXAMPLES / "milling_demo_part.toml"))
    assert done.returncode == 0, done.stderr
    assert "side-finish" in done.stdout and "rough-od" not in done.stdout
    missing = rcb(tmp_path, "demo", "--plan", "nowhere.toml")
    assert missing.returncode == 2 and "nowhere.toml" in missing.stderr
    assert "Traceback" not in missing.stderr


def test_examples_lists_every_example(tmp_path):
    listed = json.loads(rcb(tmp_path, "examples", "--json").stdout)["examples"]
    assert [e["name"] for e in listed] == NAMES
    assert {e["name"]: e["run"] for e in listed}["milling_demo_part"] == "rcb demo --milling"
    table = rcb(tmp_path, "examples")
    assert table.returncode == 0, table.stderr
    assert all(name in table.stdout for name in NAMES)


def test_copy_an_example_out_to_edit(tmp_path):
    done = rcb(tmp_path, "examples", "copy", "ivester_demo_part")
    assert done.returncode == 0, done.stderr
    copied = tmp_path / "ivester_demo_part.toml"
    assert copied.read_bytes() == (EXAMPLES / "ivester_demo_part.toml").read_bytes()
    assert not copied.is_symlink()
    # the copy is a plan rcb optimizes, from where it was copied to
    assert rcb(tmp_path, "optimize", copied.name, "--json").returncode == 0
    # never over an existing file without --force
    copied.write_text("# edited\n", encoding="utf-8")
    again = rcb(tmp_path, "examples", "copy", "ivester_demo_part")
    assert again.returncode == 2
    assert again.stderr.strip().splitlines() == [
        "rcb: error: DEST = 'ivester_demo_part.toml': exists already (--force overwrites it)"
    ]
    assert copied.read_text(encoding="utf-8") == "# edited\n"
    forced = rcb(tmp_path, "examples", "copy", "ivester_demo_part.toml", "--force")
    assert forced.returncode == 0, forced.stderr
    assert copied.read_bytes() == (EXAMPLES / "ivester_demo_part.toml").read_bytes()
    # into a directory, under its own name
    (tmp_path / "mine").mkdir()
    into = rcb(tmp_path, "examples", "copy", "borangiu_domain", "mine")
    assert into.returncode == 0, into.stderr
    assert (tmp_path / "mine" / "borangiu_domain.toml").read_bytes() == (
        EXAMPLES / "borangiu_domain.toml"
    ).read_bytes()


def test_copy_bad_input_is_one_line(tmp_path):
    unknown = rcb(tmp_path, "examples", "copy", "lathe")
    assert unknown.returncode == 2
    assert unknown.stderr.strip().splitlines() == [
        "rcb: error: NAME = 'lathe': no such example; known: " + ", ".join(NAMES)
    ]
    nowhere = rcb(tmp_path, "examples", "copy", "borangiu_domain", "no/such/dir/x.toml")
    assert nowhere.returncode == 2
    assert "DEST = 'no/such/dir/x.toml': the directory does not exist" in nowhere.stderr
    assert not (tmp_path / "no").exists()
