"""supervisor/cam pieces: cutters, compensation, arcs, the G-code reader, finishing, errors.

Also the real relief image end to end: scikit-image's ``moon.png`` (a lunar surface, 8-bit
greyscale, shipped inside the wheel) with its preview.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rs274_support import needs_rs274, run_rs274
from skimage import data as skdata
from skimage import io, transform
from typer.testing import CliRunner

from api.cli.main import app
from supervisor.cam.arcs import fit_tables, to_moves
from supervisor.cam.compensation import compensate, offset_surface
from supervisor.cam.cutter import parse_cutter
from supervisor.cam.finishing import iso_lines, scallop_height_mm
from supervisor.cam.motion import read_moves
from supervisor.cam.stock import _whole, remaining_stock
from supervisor.gcode.lexer import parse_program

ROOT = Path(__file__).resolve().parents[2]
PLAN = ROOT / "examples" / "cam_relief_part.toml"


def test_ball_compensation_of_a_spike_is_the_inverted_ball():
    # one pixel 5 mm high on a floor at 0: the tip of a Ø2 ball must stay on the ball
    # centred on the spike's top, 1 mm lower: c(d) = 5 − (1 − sqrt(1 − d²))
    h = np.zeros((41, 41))
    h[20, 20] = 5.0
    c = compensate(h, parse_cutter("ball:2"), 0.1)
    for d_px in (0, 3, 7, 10):
        d = d_px * 0.1
        assert c[20, 20 + d_px] == pytest.approx(5 - (1 - math.sqrt(1 - d * d)), abs=1e-12)
    assert c[20, 31] == 0.0  # beyond the radius: the floor


def test_bull_nose_profile():
    bull = parse_cutter("bull:10:2")
    d = np.array([0.0, 3.0, 4.0, 5.0])
    # flat to R − r = 3, then the corner: r − sqrt(r² − (d − 3)²)
    assert bull.profile_mm(d) == pytest.approx([0, 0, 2 - math.sqrt(3), 2])


def test_allowance_surface_of_a_plane_is_the_plane_raised():
    h = np.full((30, 30), 2.0)
    assert offset_surface(h, 0.5, 0.1)[5:-5, 5:-5] == pytest.approx(2.5)


@settings(max_examples=30, deadline=None)
@given(st.floats(1.0, 150.0), st.floats(0.0, 6.28), st.floats(0.2, 6.0))
def test_arcs_stay_in_one_quadrant_and_on_the_circle(radius, start, sweep):
    # a polyline on a circle: every arc it becomes spans one quadrant at most, ends on the
    # circle, and radii over the limit become lines
    t = np.linspace(start, start + sweep, 200)
    pts = np.column_stack((radius * np.cos(t), radius * np.sin(t)))
    moves = to_moves(pts, max_radius_mm=100.0)
    x0, y0 = pts[0]
    for m in moves:
        if m.centre is not None:
            assert radius <= 100.0
            a0 = math.atan2(y0, x0)
            a1 = math.atan2(m.y, m.x)
            span = (a1 - a0) % (2 * math.pi) if m.ccw else (a0 - a1) % (2 * math.pi)
            assert span <= math.pi / 2 + 1e-9
            inner = a0 + (np.linspace(0, span, 50)[1:-1] * (1 if m.ccw else -1))
            quadrants = np.floor(np.mod(inner, 2 * math.pi) / (math.pi / 2))
            assert len(set(quadrants.tolist())) <= 1  # no axis inside the arc
        assert math.hypot(m.x, m.y) == pytest.approx(radius, abs=1e-9)
        x0, y0 = m.x, m.y
    if radius > 100.0:
        assert all(m.centre is None for m in moves)
    assert (moves[-1].x, moves[-1].y) == pytest.approx(tuple(pts[-1]))


@settings(max_examples=25, deadline=None)
@given(
    st.lists(
        st.tuples(st.floats(0.5, 250.0), st.floats(0.0, 6.28), st.floats(-3.0, 3.0)),
        min_size=1,
        max_size=4,
    ),
    st.integers(0, 2**32 - 1),
)
def test_arc_tables_give_the_moves_run_by_run_fitting_gives(pieces, seed):
    # paths of arcs of any radius (over and under the limit) with straight runs and a few
    # jittered points between: the fits of every path of a level at once (fit_tables)
    # give each path's moves exactly as fitting its runs one by one
    rng = np.random.default_rng(seed)
    paths = []
    for radius, start, sweep in pieces:
        t = np.linspace(start, start + sweep, int(rng.integers(2, 90)))
        arc = np.column_stack((radius * np.cos(t), radius * np.sin(t)))
        line = arc[-1] + np.outer(np.arange(1, int(rng.integers(1, 12))), rng.normal(size=2))
        path = np.vstack((arc, line))
        path[rng.random(len(path)) < 0.05] += rng.normal(scale=1e-3, size=2)
        paths.append(path)
    tables = fit_tables(paths, 100.0)
    for path, table in zip(paths, tables, strict=True):
        assert to_moves(path, 100.0, table) == to_moves(path, 100.0)


@pytest.mark.parametrize("peak_mm", [3.0, 0.0])
def test_stock_measure_by_decreasing_vertical_stock_is_the_whole_maps(peak_mm):
    # a 200 x 200 px wavy model under a material left 0.2-0.7 mm above it, with (3.0) or
    # without (0.0) one tall spot: the batches stop early or run into the whole-map pass;
    # either way the largest distance is the one measured over every pixel
    yy, xx = np.mgrid[0:200, 0:200] * 0.1
    model = 2 + np.sin(xx / 2) * np.cos(yy / 3)
    rng = np.random.default_rng(7)
    material = model + 0.2 + 0.5 * rng.random(model.shape)
    material[90:94, 120:125] += peak_mm
    found = remaining_stock(model, material, 0.1, 0.74)
    vertical = np.clip(material - model, 0.0, None)
    gy, gx = np.gradient(model, 0.1)
    whole = _whole((model, material, gx, -gy, gx * gx + gy * gy), vertical, 0.1, 0.74)
    assert found == whole
    assert 0.2 <= found <= 0.7 + peak_mm


def test_scallop_height():
    # ball Ø6, stepover 0.5: 3 − sqrt(9 − 0.0625) = 0.010435 mm (Sandvik's formula)
    assert scallop_height_mm(parse_cutter("ball:6"), 0.5) == pytest.approx(0.0104349, rel=1e-5)
    assert scallop_height_mm(parse_cutter("bull:10:2"), 5.0) == 0.0  # flat bottom spans it


def test_bresenham_lines_cover_the_map_at_the_stepover():
    tip = np.arange(50 * 60, dtype=float).reshape(50, 60)
    lines, step = iso_lines(tip, 0.1, 0.5, 30.0)
    assert step == 0.5 and len(lines) >= 10
    for line in lines:
        cols = np.rint(line[:, 0] / 0.1).astype(int)
        rows = 49 - np.rint(line[:, 1] / 0.1).astype(int)
        assert np.array_equal(line[:, 2], tip[rows, cols])  # heights read at the points
        steps = np.abs(np.diff(np.column_stack((rows, cols)), axis=0)).max(axis=1)
        assert np.all(steps == 1)  # 8-connected, one pixel a step


@pytest.fixture(scope="module")
def moon_run(tmp_path_factory):
    """moon.png, 512 px, scaled to 128 px: 0.25 mm per pixel, z 0..4 mm."""
    tmp = tmp_path_factory.mktemp("moon")
    moon = transform.resize(skdata.moon(), (128, 128), anti_aliasing=True, preserve_range=True)
    image = tmp / "moon.png"
    io.imsave(image, np.round(moon).astype(np.uint8), check_contrast=False)
    out, preview = tmp / "moon.nc", tmp / "moon.png.preview.png"
    result = CliRunner().invoke(
        app,
        [
            "cam",
            "depthmap",
            str(image),
            "--pixel-mm",
            "0.25",
            "--z-range-mm",
            "0:4",
            "--tool",
            "flat:10",
            "--finish",
            "ball:6",
            "--stepover-mm",
            "0.75",
            "--form-tolerance-mm",
            "0.2",
            "--plan",
            str(PLAN),
            "--operation",
            "rough",
            "--out",
            str(out),
            "--preview",
            str(preview),
            "--verify",
            "--json",
        ],
    )
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout), out.read_text(), preview


def test_moon_end_to_end_with_preview(moon_run):
    data, program, preview = moon_run
    assert data["gouge_mm"] <= 4 / 255  # one grey level
    assert data["passes"] >= 1 and data["finishing"]["lines"] > 0
    # craters narrower than the Ø10 mm end mill keep more than the allowance: reported
    assert 0.5 <= data["max_remaining_stock_mm"] < 4
    assert preview.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert set(data) == {
        "levels",
        "passes",
        "finishing",
        "gouge_mm",
        "max_remaining_stock_mm",
        "cycle_time_min",
    }
    assert set(data["levels"][0]) == {
        "z_mm",
        "depth_mm",
        "paths",
        "length_mm",
        "setpoint",
        "time_min",
    }


def test_program_is_read_by_the_projects_gcode_reader(moon_run):
    _, program, _ = moon_run
    blocks = parse_program(program)
    assert all(b.problem is None for b in blocks)
    assert program.splitlines()[2] == "G21 G90 G17 G94"
    moves = read_moves(program)
    arcs = [m for m in moves if m.centre is not None]
    assert all(m.feed_mm_min > 0 for m in moves if not m.rapid)
    for m in arcs:  # one quadrant, radius under the limit
        a0, a1, r = m.sweep()
        assert abs(a1 - a0) <= math.pi / 2 + 1e-3 and r <= 200
    assert " M3" in program and "(level " in program and "(path 1 of" in program


@needs_rs274
def test_rs274_reads_the_moon_program_with_the_same_cycle_time(moon_run, tmp_path):
    data, program, _ = moon_run
    canon = run_rs274(program, tmp_path, {1: 10, 2: 6})
    assert canon.cycle_min == pytest.approx(data["cycle_time_min"], rel=1e-3)


BAD = [
    (["IMAGE_MISSING"], "IMAGE"),
    (["--pixel-mm", "0"], "--pixel-mm"),
    (["--z-range-mm", "5:1"], "--z-range-mm"),
    (["--z-range-mm", "abc"], "--z-range-mm"),
    (["--tool", "flat:50"], "--tool"),
    (["--tool", "ball:6"], "--tool"),
    (["--tool", "cone:3"], "--tool"),
    (["--operation", "nope"], "--operation"),
    (["--finish", "ball:8"], "--finish-operation"),
    (["--stock-top-mm", "1"], "--stock-top-mm"),
    (["COLOUR"], "IMAGE"),
]


@pytest.mark.parametrize(("change", "option"), BAD)
def test_bad_input_is_one_line_naming_the_option(tmp_path, change, option):
    grey = np.zeros((40, 40), dtype=np.uint8)
    grey[10:30, 10:30] = 200
    image = tmp_path / "m.png"
    io.imsave(image, grey, check_contrast=False)
    args = {
        "--pixel-mm": "1",
        "--z-range-mm": "0:5",
        "--tool": "flat:10",
        "--plan": str(PLAN),
        "--operation": "rough",
        "--out": str(tmp_path / "o.nc"),
    }
    first = str(image)
    if change == ["IMAGE_MISSING"]:
        first = str(tmp_path / "missing.png")
    elif change == ["COLOUR"]:
        colour = np.zeros((40, 40, 3), dtype=np.uint8)
        colour[..., 0] = 255
        io.imsave(image, colour, check_contrast=False)
    else:
        args[change[0]] = change[1]
    argv = ["cam", "depthmap", first] + [x for kv in args.items() for x in kv]
    result = CliRunner().invoke(app, argv)
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and option in lines[0], result.stderr
    assert not (tmp_path / "o.nc").exists()
