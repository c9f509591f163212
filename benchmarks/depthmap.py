"""Benchmark of ``rcb cam depthmap`` on a 1000 x 1000 pixel map (issue 19: <= 30 s end to end).

The map is made here: 100 x 100 mm at 0.1 mm per pixel, 16-bit, z 0..20 mm: three domes, a
pyramid and a step on a floor. The command runs end to end as a user runs it (roughing with a
Ø10 flat end mill, finishing with a Ø6 ball, --verify, --preview) in a subprocess, timed by
wall clock; a reference on the same machine in the same run is one grey-scale dilation of
the map by the Ø6 ball (scipy), so the ratio says how the whole chain compares with its
largest single image operation, whatever the machine's speed.

``--against REV`` also runs the code of that git revision (exported with ``git archive`` to a
temporary folder and put first on ``PYTHONPATH``), alternating with this one ``--runs`` times,
on the same map: the ratio of the two wall clocks says what a change cost on this machine in
this sitting.

    .venv/bin/python benchmarks/depthmap.py [--side 1000] [--against main] [--runs 2]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from skimage import io

ROOT = Path(__file__).resolve().parents[1]
PLAN = ROOT / "examples" / "cam_relief_part.toml"


def relief(side: int, pixel_mm: float) -> np.ndarray:
    """Three domes, a pyramid and a step [mm]."""
    yy, xx = np.mgrid[0:side, 0:side] * pixel_mm
    size = side * pixel_mm
    h = np.zeros((side, side))
    for cx, cy, r in ((0.25, 0.25, 0.18), (0.7, 0.3, 0.12), (0.3, 0.72, 0.1)):
        d = np.hypot(xx - cx * size, yy - cy * size)
        h = np.maximum(h, np.sqrt(np.clip((r * size) ** 2 - d * d, 0, None)))
    pyr = 12 - 0.8 * np.maximum(abs(xx - 0.72 * size), abs(yy - 0.72 * size))
    h = np.maximum(h, np.clip(pyr, 0, None))
    block = (xx < 0.2 * size) & (yy > 0.55 * size)  # a step at the map's edge
    h[block] = np.maximum(h[block], 6.0)
    return np.clip(h, 0, 20)


def _command(python: str, image: Path, tmp: Path, pixel: float) -> list[str]:
    """``rcb cam depthmap`` with the benchmark's options, run by ``python``."""
    return [
        python,
        "-c",
        "from api.cli.main import app; app()",
        "cam",
        "depthmap",
        str(image),
        "--pixel-mm",
        str(pixel),
        "--z-range-mm",
        "0:20",
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
        "--out",
        str(tmp / "relief.nc"),
        "--preview",
        str(tmp / "preview.png"),
        "--verify",
        "--json",
    ]


def _timed(command: list[str], source: Path) -> tuple[float, dict, int]:
    """Wall clock [s], the JSON and the program's line count of one run from ``source``."""
    env = dict(os.environ, PYTHONPATH=str(source))
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, cwd=source, env=env)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        sys.exit(done.stderr)
    lines = Path(command[command.index("--out") + 1]).read_text().count("\n")
    return wall, json.loads(done.stdout), lines


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--side", type=int, default=1000)
    parser.add_argument("--against", help="a git revision to time in the same run")
    parser.add_argument("--runs", type=int, default=1)
    args = parser.parse_args()
    pixel = 0.1
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        image = tmp / "relief.png"
        heights = relief(args.side, pixel)
        io.imsave(image, np.round(heights / 20 * 65535).astype(np.uint16), check_contrast=False)
        from scipy import ndimage

        from supervisor.cam.cutter import parse_cutter

        footprint, structure = parse_cutter("ball:6").kernel(pixel)
        start = time.perf_counter()
        ndimage.grey_dilation(heights, footprint=footprint, structure=structure)
        reference = time.perf_counter() - start
        old = None
        if args.against:
            old = tmp / "previous"
            old.mkdir()
            archive = subprocess.run(
                ["git", "archive", args.against], cwd=ROOT, capture_output=True, check=True
            )
            subprocess.run(["tar", "-x", "-C", str(old)], input=archive.stdout, check=True)
        command = _command(sys.executable, image, tmp, pixel)
        walls: list[float] = []
        before: list[float] = []
        for _ in range(args.runs):
            wall, data, lines = _timed(command, ROOT)
            walls.append(wall)
            if old is not None:
                wall_old, data_old, lines_old = _timed(command, old)
                before.append(wall_old)
    print(f"map {args.side} x {args.side} px at {pixel} mm, 16-bit, z 0..20 mm")
    print(
        f"levels {data['passes']}, program lines {lines}, gouge {data['gouge_mm']:.5f} mm,"
        f" stock after roughing {data['max_remaining_stock_mm']:.4f} mm,"
        f" cycle {data['cycle_time_min']:.1f} min"
    )
    wall = max(walls)
    print(
        f"end to end (rcb cam depthmap --verify --preview): "
        f"{', '.join(f'{w:.1f}' for w in walls)} s (target <= 30 s:"
        f" {'met' if wall <= 30 else 'NOT met'})"
    )
    print(
        f"reference, one Ø6 ball dilation of the map: {reference:.2f} s;"
        f" ratio {wall / reference:.1f}"
    )
    if before:
        print(
            f"{args.against}: {', '.join(f'{w:.1f}' for w in before)} s, levels"
            f" {data_old['passes']}, program lines {lines_old}, gouge"
            f" {data_old['gouge_mm']:.5f} mm; this code / {args.against}:"
            f" {', '.join(f'{w / b:.2f}' for w, b in zip(walls, before, strict=True))}"
        )


if __name__ == "__main__":
    main()
