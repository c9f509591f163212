"""Issue 28: the finishing cutter's contact, checked against OpenCAMLib and exact offsets.

The surface convention (supervisor/cam/dropcutter.py): a map is the triangulated surface
through its pixel centres, each square split along the diagonal from (row, col) to
(row + 1, col + 1). OpenCAMLib (PyPI ``opencamlib``, installed by the test extra, never
vendored) is given exactly those triangles, and its ``BatchDropCutter`` says where the same
cutter touches them. Checked at every point of the finishing program that ``rcb cam
depthmap`` writes: never more than one grey level below OpenCAMLib's contact height, and on
the analytic shapes never below the exact offset of the shape with its wall moved one pixel.
Every program is also read by LinuxCNC's ``rs274`` (tests/rs274_support.py).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
from opencamlib import ocl
from rs274_support import needs_rs274, run_rs274
from skimage import data as skdata
from skimage import io, transform
from typer.testing import CliRunner

from api.cli.main import app
from supervisor.cam import job
from supervisor.cam.compensation import compensate, compensate_rows
from supervisor.cam.cutter import Cutter, parse_cutter
from supervisor.cam.depthmap import grey_to_depthmap
from supervisor.cam.dropcutter import drop_map
from supervisor.cam.feeds import Feeds, milling_operation
from supervisor.cam.motion import read_moves
from supervisor.cam.program import FINISH_TOOL
from supervisor.inputs.plan import load_plan

ROOT = Path(__file__).resolve().parents[2]
PLAN = ROOT / "examples" / "cam_relief_part.toml"
PIXEL = 0.25
BALL_R = 3.0  # ball:6


def ocl_drop(height: np.ndarray, cutter: Cutter, pixel: float, xy: np.ndarray) -> np.ndarray:
    """OpenCAMLib's tip heights at the points ``xy`` (mm) on the map's triangles."""
    rows, cols = height.shape
    surface = ocl.STLSurf()

    def vertex(r: int, c: int) -> ocl.Point:
        return ocl.Point(c * pixel, (rows - 1 - r) * pixel, float(height[r, c]))

    for r in range(rows - 1):
        for c in range(cols - 1):
            surface.addTriangle(ocl.Triangle(vertex(r, c), vertex(r, c + 1), vertex(r + 1, c + 1)))
            surface.addTriangle(ocl.Triangle(vertex(r, c), vertex(r + 1, c + 1), vertex(r + 1, c)))
    length = 100.0
    if cutter.kind == "ball":
        tool = ocl.BallCutter(cutter.diameter_mm, length)
    elif cutter.kind == "flat":
        tool = ocl.CylCutter(cutter.diameter_mm, length)
    else:
        tool = ocl.BullCutter(cutter.diameter_mm, cutter.corner_radius_mm, length)
    batch = ocl.BatchDropCutter()
    # kd-tree leaves of 20 triangles, not 1: the same triangles are tested and the same
    # heights found (checked equal), in half the time (the tree is shallower to search)
    batch.setBucketSize(20)
    batch.setSTL(surface)
    batch.setCutter(tool)
    batch.setThreads(1)
    start = float(height.min()) - 2 * cutter.diameter_mm
    for x, y in xy:
        batch.appendPoint(ocl.CLPoint(float(x), float(y), start))
    batch.run()
    return np.array([p.z for p in batch.getCLPoints()])


def finishing_points(program: str) -> np.ndarray:
    """The points the finishing program moves through (its feed moves' ends), (n, 3)."""
    ends = [m.end for m in read_moves(program) if m.tool == FINISH_TOOL and not m.rapid]
    return np.array(ends)


def cam(
    tmp: Path, image: Path, z_high: float, stepover: float, *extra: str, pixel: float = PIXEL
) -> tuple[dict, str]:
    out = tmp / "p.nc"
    args = ["cam", "depthmap", str(image), "--pixel-mm", str(pixel), "--z-range-mm"]
    args += [f"0:{z_high}", "--tool", "flat:10", "--finish", "ball:6", "--stepover-mm"]
    args += [str(stepover), "--plan", str(PLAN), "--operation", "rough", "--out", str(out)]
    result = CliRunner().invoke(app, [*args, *extra, "--verify", "--json"])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout), out.read_text()


def save16(tmp: Path, heights: np.ndarray, z_high: float) -> tuple[Path, np.ndarray]:
    """A 16-bit map and the heights it holds (quantised) [mm]."""
    grey = np.round(heights / z_high * 65535).astype(np.uint16)
    image = tmp / "map.png"
    io.imsave(image, grey, check_contrast=False)
    return image, grey / 65535 * z_high


N = 160  # 40 mm square at 0.25 mm per pixel: the --verify test's map

# The shapes checked against OpenCAMLib: the same 40 mm square at 0.5 mm per pixel. The
# property (never a grey level below OpenCAMLib's contact, nor below the exact offset one
# pixel out) holds on any grid; OpenCAMLib's cost grows with the triangles under the ball
# times the program's points, 8 times fewer here than at 0.25 mm (111 s -> 4.4 s for the three).
SHAPE_PIXEL = 0.5
M = 80
CENTRE_X, CENTRE_Y = M // 2 * SHAPE_PIXEL, (M - 1 - M // 2) * SHAPE_PIXEL  # y counts rows up


def _radius(n: int = M, pixel: float = SHAPE_PIXEL) -> np.ndarray:
    """Distance from the map's centre pixel (n // 2, n // 2) [mm]."""
    yy, xx = np.mgrid[0:n, 0:n]
    return np.hypot(yy - n // 2, xx - n // 2) * pixel


def hemisphere_offset(rho: np.ndarray) -> np.ndarray:
    """Ball r on a sphere R on a floor: max(0, sqrt((R + r)² − ρ²) − r)."""
    big = 12.0 + BALL_R
    return np.maximum(0.0, np.sqrt(np.clip(big * big - rho * rho, 0, None)) - BALL_R)


CONE_H, CONE_R = 8.0, 12.0


def cone_offset(rho: np.ndarray) -> np.ndarray:
    """Ball r on a cone (apex CONE_H, base radius CONE_R) on a floor: floor, apex or side."""
    k = CONE_H / CONE_R
    out = np.zeros_like(rho)
    apex = rho <= BALL_R
    out[apex] = CONE_H - (BALL_R - np.sqrt(BALL_R**2 - rho[apex] ** 2))
    reach = BALL_R * k / math.hypot(1, k)  # the contact lies this far nearer the axis
    side = (rho - reach >= 0) & (rho - reach <= CONE_R)
    out[side] = np.maximum(out[side], CONE_H - k * rho[side] + BALL_R * (math.hypot(1, k) - 1))
    return out


STEP_COL = M // 2  # the map is 8 mm from this column on, 0 before it


def step_offset(x: np.ndarray, wall: float) -> np.ndarray:
    """Ball r against a step 8 mm high whose wall stands at x = wall [mm]."""
    gap = wall - x
    out = np.where(gap <= 0, 8.0, 0.0)
    near = (gap > 0) & (gap <= BALL_R)
    out[near] = 8.0 - (BALL_R - np.sqrt(BALL_R**2 - gap[near] ** 2))
    return out


SHAPES = {
    # name: heights, z_high, the exact offset of the shape with its wall one pixel further
    "hemisphere": (
        lambda: np.sqrt(np.clip(144 - _radius() ** 2, 0, None)),
        12.0,
        lambda xy: hemisphere_offset(
            np.hypot(xy[:, 0] - CENTRE_X, xy[:, 1] - CENTRE_Y) + SHAPE_PIXEL
        ),
    ),
    "cone": (
        lambda: np.clip(CONE_H - CONE_H / CONE_R * _radius(), 0, None),
        CONE_H,
        lambda xy: cone_offset(np.hypot(xy[:, 0] - CENTRE_X, xy[:, 1] - CENTRE_Y) + SHAPE_PIXEL),
    ),
    "step": (
        lambda: np.where(np.arange(M)[None, :] >= STEP_COL, 8.0, 0.0) * np.ones((M, 1)),
        8.0,
        # the map puts the wall between columns 39 and 40: at 39.5 px, moved one pixel
        lambda xy: step_offset(xy[:, 0], (STEP_COL - 0.5) * SHAPE_PIXEL + SHAPE_PIXEL),
    ),
}


@pytest.fixture(scope="module", params=sorted(SHAPES))
def shape_run(request, tmp_path_factory):
    make, z_high, _ = SHAPES[request.param]
    tmp = tmp_path_factory.mktemp(request.param)
    image, held = save16(tmp, make(), z_high)
    data, program = cam(tmp, image, z_high, 1.0, pixel=SHAPE_PIXEL)
    return request.param, held, z_high / 65535, data, program, tmp


def test_finishing_never_below_opencamlib_on_the_analytic_shapes(shape_run):
    name, held, grey, data, program, _ = shape_run
    points = finishing_points(program)
    contact = ocl_drop(held, parse_cutter("ball:6"), SHAPE_PIXEL, points[:, :2])
    below = contact - points[:, 2]
    assert below.max() <= grey, (name, below.max())
    # and the program is not lifted off the surface either: 4-decimal G-code
    assert below.min() >= -1e-4, (name, below.min())
    assert data["gouge_mm"] <= grey


def test_finishing_never_below_the_exact_offset_one_pixel_out(shape_run):
    name, _, grey, _, program, _ = shape_run
    points = finishing_points(program)
    exact = SHAPES[name][2](points[:, :2])
    assert (exact - points[:, 2]).max() <= grey, name


@needs_rs274
def test_rs274_reads_the_program_and_agrees_on_the_cycle_time(shape_run):
    _, _, _, data, program, tmp = shape_run
    canon = run_rs274(program, tmp, {1: 10, 2: 6})
    assert canon.commands["ARC_FEED"] > 0 and canon.commands["STRAIGHT_FEED"] > 0
    assert canon.cycle_min == pytest.approx(data["cycle_time_min"], rel=1e-3)


@pytest.fixture(scope="module")
def moon(tmp_path_factory):
    """scikit-image's moon.png at 64 px, 0.5 mm per pixel (the 32 mm square it was at 128 px
    and 0.25 mm, on the shapes' coarser grid: 36 s -> 5 s), z 0..4 mm (8-bit)."""
    tmp = tmp_path_factory.mktemp("moon")
    grey = transform.resize(skdata.moon(), (64, 64), anti_aliasing=True, preserve_range=True)
    grey = np.round(grey).astype(np.uint8)
    image = tmp / "moon.png"
    io.imsave(image, grey, check_contrast=False)
    data, program = cam(tmp, image, 4.0, 0.75, "--form-tolerance-mm", "0.2", pixel=SHAPE_PIXEL)
    return grey / 255 * 4.0, data, program, tmp


def test_moon_finishing_never_below_opencamlib(moon):
    held, data, program, _ = moon
    points = finishing_points(program)
    contact = ocl_drop(held, parse_cutter("ball:6"), SHAPE_PIXEL, points[:, :2])
    assert (contact - points[:, 2]).max() <= 4 / 255
    assert data["gouge_mm"] <= 4 / 255


@needs_rs274
def test_rs274_reads_the_moon_program(moon):
    _, data, program, tmp = moon
    canon = run_rs274(program, tmp, {1: 10, 2: 6})
    assert canon.cycle_min == pytest.approx(data["cycle_time_min"], rel=1e-3)


@pytest.mark.parametrize("spec", ["ball:6", "flat:4", "bull:6:1"])
def test_drop_cutter_is_opencamlibs_on_a_rough_map(spec):
    # a random rough map with a 4 mm cliff: every contact kind (vertex, edge, facet) occurs
    rng = np.random.default_rng(1)
    height = rng.uniform(0, 3, (40, 40))
    height[:, 20:] += 4
    cutter = parse_cutter(spec)
    mine = drop_map(height, cutter, PIXEL)
    rows, cols = np.mgrid[0:40:3, 0:40]
    xy = np.column_stack((cols.ravel() * PIXEL, (39 - rows.ravel()) * PIXEL))
    reference = ocl_drop(height, cutter, PIXEL, xy)
    ours = mine[rows.ravel(), cols.ravel()]
    # bull nose: its edge contact by 50 bisections; OpenCAMLib's by its own iteration
    assert np.abs(ours - reference).max() <= (1e-12 if cutter.kind != "bull" else 1e-9)
    # the pixel centres alone (the dilation) lie well below: up to 0.9-1.9 mm here
    assert (reference - compensate(height, cutter, PIXEL)[rows, cols].ravel()).max() > 0.5


def test_verify_sees_the_gouge_of_a_program_made_from_the_pixel_centres_alone():
    """--verify sweeps the program against points between the pixel centres.

    The program made by dropping the ball on the pixel centres alone (the code before issue
    28) gouges the hemisphere's foot by 0.177 mm, and --verify says so; the same
    simulation reported 5e-5 mm when it looked at the pixel centres only.
    """
    grey = np.round(np.sqrt(np.clip(144 - _radius(N, PIXEL) ** 2, 0, None)) / 12 * 65535)
    depth = grey_to_depthmap(grey.astype(np.int64), 65536, PIXEL, (0, 12))
    plan = load_plan(PLAN)
    rough, ball = parse_cutter("flat:10"), parse_cutter("ball:6")
    feeds = Feeds(plan, milling_operation(plan, "rough", rough, "op"))
    finish = (ball, Feeds(plan, milling_operation(plan, "finish", ball, "op")))
    settings = job.CamSettings()
    with mock.patch.object(job, "drop_rows", compensate_rows):
        before = job.run_cam(depth, rough, feeds, finish, settings, verify=True)
    after = job.run_cam(depth, rough, feeds, finish, settings, verify=True)
    assert before.verification is not None and after.verification is not None
    assert before.verification.gouge_mm == pytest.approx(0.177, abs=0.001)
    assert after.verification.gouge_mm <= 12 / 65535
