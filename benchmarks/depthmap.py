"""Benchmark of ``rcb cam depthmap`` on a 1000 x 1000 pixel map (issue 19: <= 30 s end to end).

The map is made here: 100 x 100 mm at 0.1 mm per pixel, 16-bit, z 0..20 mm: three domes, a
pyramid and a step on a floor. The command runs end to end as a user runs it (roughing with a
Ø10 flat end mill, finishing with a Ø6 ball, --verify, --preview) in a subprocess, timed by
wall clock; a reference on the same machine in the same run is one grey-scale dilation of
the map by the Ø6 ball (scipy), so the ratio says how the whole chain compares with its
largest single image operation, whatever the machine's speed.

    .venv/bin/python benchmarks/depthmap.py [--side 1000]
"""

from __future__ import annotations

import argparse
import json
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


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--side", type=int, default=1000)
    args = parser.parse_args()
    pixel = 0.1
    with tempfile.TemporaryDirectory() as tmp:
        image = Path(tmp) / "relief.png"
        heights = relief(args.side, pixel)
        io.imsave(image, np.round(heights / 20 * 65535).astype(np.uint16), check_contrast=False)
        from scipy import ndimage

        from supervisor.cam.cutter import parse_cutter

        footprint, structure = parse_cutter("ball:6").kernel(pixel)
        start = time.perf_counter()
        ndimage.grey_dilation(heights, footprint=footprint, structure=structure)
        reference = time.perf_counter() - start
        command = [
            str(Path(sys.executable).parent / "rcb"),
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
            str(Path(tmp) / "relief.nc"),
            "--preview",
            str(Path(tmp) / "preview.png"),
            "--verify",
            "--json",
        ]
        start = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, cwd=ROOT, check=False)
        wall = time.perf_counter() - start
        if done.returncode != 0:
            sys.exit(done.stderr)
        data = json.loads(done.stdout)
        lines = (Path(tmp) / "relief.nc").read_text().count("\n")
    print(f"map {args.side} x {args.side} px at {pixel} mm, 16-bit, z 0..20 mm")
    print(
        f"levels {data['passes']}, program lines {lines}, gouge {data['gouge_mm']:.5f} mm,"
        f" stock after roughing {data['max_remaining_stock_mm']:.4f} mm,"
        f" cycle {data['cycle_time_min']:.1f} min"
    )
    print(
        f"end to end (rcb cam depthmap --verify --preview): {wall:.1f} s (target <= 30 s:"
        f" {'met' if wall <= 30 else 'NOT met'})"
    )
    print(
        f"reference, one Ø6 ball dilation of the map: {reference:.2f} s;"
        f" ratio {wall / reference:.1f}"
    )


if __name__ == "__main__":
    main()
