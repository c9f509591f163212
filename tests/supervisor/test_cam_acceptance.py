"""Issue 19 acceptance: hemisphere, pyramid and step end to end, verified by simulation.

Each shape is a 16-bit PNG at 0.1 mm per pixel, roughed with a Ø10 mm flat end mill and
finished with a Ø6 mm ball (``examples/cam_relief_part.toml``), through ``rcb cam depthmap
--verify --json``. Checked: the gouge is 0 within one grey level, the stock left after
roughing is at most the allowance + 0.05 mm, every pass depth is at most the optimiser's
axial limit, and the pass count is the gradient rule's (supervisor/cam/levels.py) worked
out by hand from the shape's geometry. Each program is also read by LinuxCNC's ``rs274``
(issue 28), whose canonical moves give the same cycle time.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from rs274_support import needs_rs274, run_rs274
from skimage import io
from typer.testing import CliRunner

from api.cli.main import app
from supervisor.cam.cutter import parse_cutter
from supervisor.cam.feeds import Feeds, milling_operation
from supervisor.inputs.plan import load_plan

ROOT = Path(__file__).resolve().parents[2]
PLAN = ROOT / "examples" / "cam_relief_part.toml"
PIXEL = 0.1
ALLOWANCE = 0.5  # the command's default
# the form tolerance the hand counts are for (given: with --finish the default is the allowance)
TOLERANCE = 0.04


@pytest.fixture(scope="module")
def ap_max() -> float:
    """The optimiser's axial limit for the roughing cutter (4.895 mm on this plan)."""
    plan = load_plan(PLAN)
    cutter = parse_cutter("flat:10")
    return (
        Feeds(plan, milling_operation(plan, "rough", cutter, "op"))
        .limits(cutter)
        .max_axial_depth_mm
    )


def _run(tmp_path: Path, heights: np.ndarray, z_high: float) -> tuple[dict, str]:
    image = tmp_path / "map.png"
    io.imsave(image, np.round(heights / z_high * 65535).astype(np.uint16), check_contrast=False)
    out = tmp_path / "p.nc"
    result = CliRunner().invoke(
        app,
        [
            "cam",
            "depthmap",
            str(image),
            "--pixel-mm",
            str(PIXEL),
            "--z-range-mm",
            f"0:{z_high}",
            "--tool",
            "flat:10",
            "--finish",
            "ball:6",
            "--stepover-mm",
            "0.5",
            "--plan",
            str(PLAN),
            "--operation",
            "rough",
            "--form-tolerance-mm",
            str(TOLERANCE),
            "--out",
            str(out),
            "--verify",
            "--json",
        ],
    )
    assert result.exit_code == 0, result.output
    assert out.read_text().startswith("%\n")
    return json.loads(result.stdout), out.read_text()


def _hemisphere() -> np.ndarray:
    n = 441  # 44 mm square, the hemisphere of radius 20 mm in the middle
    yy, xx = np.mgrid[0:n, 0:n]
    r = np.hypot(yy - 220, xx - 220) * PIXEL
    return np.sqrt(np.clip(400 - r * r, 0, None))


def _pyramid() -> np.ndarray:
    n = 341  # a square pyramid 30 mm across and 5 mm high on a 34 mm floor
    yy, xx = np.mgrid[0:n, 0:n]
    return np.clip(5 - (1 / 3) * np.maximum(abs(yy - 170), abs(xx - 170)) * PIXEL, 0, None)


def _step() -> np.ndarray:
    n = 201  # a 20 mm square: floor at 0 on the left half, 8 mm on the right, stock at 8
    h = np.zeros((n, n))
    h[:, 100:] = 8.0
    return h


SHAPES: dict[str, tuple[Callable[[], np.ndarray], float]] = {
    "hemisphere": (_hemisphere, 20.0),
    "pyramid": (_pyramid, 5.0),
    "step": (_step, 8.0),
}


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> Callable[[str], tuple[dict, str]]:
    """Each shape run once per module: its JSON and its program."""
    done: dict[str, tuple[dict, str]] = {}

    def run(name: str) -> tuple[dict, str]:
        if name not in done:
            make, z_high = SHAPES[name]
            done[name] = _run(tmp_path_factory.mktemp(name), make(), z_high)
        return done[name]

    return run


def _common(data: dict, ap_max: float, z_high: float) -> None:
    grey_level = z_high / 65535
    assert data["gouge_mm"] <= grey_level
    assert data["max_remaining_stock_mm"] <= ALLOWANCE + 0.05
    assert max(level["depth_mm"] for level in data["levels"]) <= ap_max + 1e-9
    assert data["passes"] == len(data["levels"])
    assert data["cycle_time_min"] > sum(level["time_min"] for level in data["levels"])


def _by_hand(top: float, floor: float, ap_max: float, least_slope) -> int:
    """The gradient rule: main passes of at most ap_max, each split to ε·sqrt(1 + g²)."""
    mains = math.ceil((top - floor) / ap_max)
    step = (top - floor) / mains
    total = 0
    for i in range(mains):
        g = least_slope(top - i * step, top - (i + 1) * step)
        total += 1 if g is None else math.ceil(step / (TOLERANCE * math.hypot(1, g)))
    return total


def test_hemisphere(runs, ap_max):
    data, _ = runs("hemisphere")
    _common(data, ap_max, 20.0)
    # by hand: s_a is a sphere of radius 20.5 above a floor at 0.5; its least slope in a
    # band (l, u) is at the band's top, sqrt(20.5² − u²)/u
    hand = _by_hand(20.0, 0.5, ap_max, lambda u, low: math.sqrt(20.5**2 - u * u) / u)
    assert hand == 302  # 119 + 90 + 61 + 32 (4 main passes of 4.875 mm)
    # the rule reads the slopes on the model's grey levels (levels.py, rule 3): within
    # 0.6 % of these (16-bit quantisation), and never across a whole pass
    assert data["passes"] == hand


def test_pyramid(runs, ap_max):
    data, _ = runs("pyramid")
    _common(data, ap_max, 5.0)
    # by hand: faces of slope 1/3; the allowance rounds the diagonal ridges, whose top line
    # falls at (1/3)/√2 along the diagonal (the ridge pixels' central differences on the
    # model read the same): the least slope; one main pass 5 → 0.5
    hand = _by_hand(5.0, 0.5, ap_max, lambda u, low: (1 / 3) / math.sqrt(2))
    assert hand == 110  # ceil(4.5 / (0.04 · 1.0274)) = ceil(109.5)
    assert data["passes"] == hand


def test_step(runs, ap_max):
    data, _ = runs("step")
    _common(data, ap_max, 8.0)
    # by hand: plateaus at 8.5 (the top, above the stock: none) and 0.5; the wall has no
    # pixel between them: main passes only, ceil(7.5 / 4.895) = 2
    assert data["passes"] == _by_hand(8.0, 0.5, ap_max, lambda u, low: None) == 2


@needs_rs274
@pytest.mark.parametrize("name", sorted(SHAPES))
def test_rs274_reads_the_program_with_the_same_cycle_time(runs, name, tmp_path):
    data, program = runs(name)
    canon = run_rs274(program, tmp_path, {1: 10, 2: 6})
    assert canon.commands["STRAIGHT_FEED"] > 0 and canon.commands["CHANGE_TOOL"] == 2
    assert canon.cycle_min == pytest.approx(data["cycle_time_min"], rel=1e-3)
