"""`rcb cam depthmap`'s form tolerance when none is given (issue 30: a sensible moon.png program).

Before a finishing pass the stair may be as thick as the allowance (the finisher's setpoint is
planned at allowance + form tolerance); without one the levels are the final form (0.04 mm).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from skimage import data as skdata
from skimage import io, transform
from typer.testing import CliRunner

from api.cli.main import app
from supervisor.cam.job import FORM_TOLERANCE_MM, default_form_tolerance_mm

PLAN = Path(__file__).resolve().parents[2] / "examples" / "cam_relief_part.toml"


def test_default_form_tolerance_is_the_allowance_before_a_finish():
    assert default_form_tolerance_mm(0.5, finishing=True) == 0.5
    assert default_form_tolerance_mm(0.3, finishing=True) == 0.3
    assert default_form_tolerance_mm(0.5, finishing=False) == FORM_TOLERANCE_MM == 0.04
    # no allowance: the roughing levels are the form the finisher meets
    assert default_form_tolerance_mm(0.0, finishing=True) == FORM_TOLERANCE_MM


@pytest.fixture(scope="module")
def moon(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """moon.png scaled to 64 px at 0.5 mm: the same relief, 32 mm square, z 0..4 mm."""
    image = tmp_path_factory.mktemp("moon") / "moon.png"
    small = transform.resize(skdata.moon(), (64, 64), anti_aliasing=True, preserve_range=True)
    io.imsave(image, np.round(small).astype(np.uint8), check_contrast=False)
    return image


def _run(moon: Path, tmp: Path, *extra: str) -> tuple[dict, str]:
    out = tmp / f"p{len(list(tmp.iterdir()))}.nc"
    args = ["cam", "depthmap", str(moon), "--pixel-mm", "0.5", "--z-range-mm", "0:4"]
    args += ["--tool", "flat:10", "--plan", str(PLAN), "--operation", "rough"]
    result = CliRunner().invoke(app, [*args, *extra, "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout), out.read_text()


def test_with_a_finish_the_default_is_the_allowance(moon: Path, tmp_path: Path):
    finish = ("--finish", "ball:6", "--stepover-mm", "1")
    default, program = _run(moon, tmp_path, *finish)
    given, same = _run(moon, tmp_path, *finish, "--form-tolerance-mm", "0.5")
    fine, _ = _run(moon, tmp_path, *finish, "--form-tolerance-mm", "0.04")
    assert program == same
    assert default["passes"] < fine["passes"] / 3  # stairs of 0.04 mm: many rest levels
    assert default["cycle_time_min"] < fine["cycle_time_min"]


def test_without_a_finish_the_default_is_the_fine_form(moon: Path, tmp_path: Path):
    _, program = _run(moon, tmp_path)
    _, same = _run(moon, tmp_path, "--form-tolerance-mm", "0.04")
    assert program == same
