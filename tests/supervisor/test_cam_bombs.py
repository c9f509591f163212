"""rcb cam depthmap: an image too large is refused from its header, in bounded memory (issue 29).

The images of the issue (a 30000^2 16-bit TIFF, a 13000^2 PNG), small on disk, are handed to
the ``rcb`` executable in its own process (``benchmarks/depthmap_bombs.py``): exit 2, one line
naming the file and its size, a peak under 200 MB (before the check: 8.2 GB and 1.54 GB). The
child's address space is capped, so a regression fails here instead of swapping the machine.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from api.cli.main import app
from models.errors import MAX_ECHO, InputError
from supervisor.cam.depthmap import MAX_SIDE_PX, read_depthmap

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT / "benchmarks") not in sys.path:
    sys.path.insert(0, str(ROOT / "benchmarks"))

from depthmap_bombs import (  # noqa: E402
    TARGET_MB,
    png_of_one_grey,
    refuse,
    tiff_of_one_grey,
)

#: The child's address space [bytes]: far above a refusal, far below decoding 30000^2 pixels.
CAP = 3 * 1024**3


@pytest.mark.parametrize(
    ("write", "side", "bits"),
    [
        (tiff_of_one_grey, 30000, 16),
        (tiff_of_one_grey, 30000, 8),
        (png_of_one_grey, 13000, 8),
        (png_of_one_grey, 30000, 16),
        (tiff_of_one_grey, MAX_SIDE_PX + 1, 16),  # one pixel over: under Pillow's own guard
    ],
    ids=["tiff-30000-16bit", "tiff-30000-8bit", "png-13000-8bit", "png-30000-16bit", "tiff-4001"],
)
def test_a_large_image_is_refused_from_its_header(tmp_path, write, side, bits):
    suffix = ".tif" if write is tiff_of_one_grey else ".png"
    image = write(tmp_path / f"map{suffix}", side, bits)
    assert image.stat().st_size < 2_000_000  # small on disk, huge decoded
    result = refuse(image, tmp_path, address_space=CAP)
    assert result.exit_code == 2, result.stderr
    assert result.stderr == (
        f"rcb: error: IMAGE = {str(image)!r}: is {side} x {side} pixels (from its header); "
        f"a depth map is at most {MAX_SIDE_PX} x {MAX_SIDE_PX} pixels: refused before decoding\n"
    )
    assert result.peak_mb < TARGET_MB
    assert not (tmp_path / "p.nc").exists()


@pytest.mark.parametrize(("write", "bits"), [(tiff_of_one_grey, 16), (png_of_one_grey, 8)])
def test_an_image_within_the_budget_is_read(tmp_path, write, bits):
    """The check reads headers only: a map the generator writes decodes as it should."""
    image = write(tmp_path / ("m.tif" if bits == 16 else "m.png"), 64, bits)
    depth = read_depthmap(image, 0.5, (-3.0, 7.0))
    assert depth.height_mm.shape == (64, 64)
    assert depth.levels == 2**bits
    np.testing.assert_array_equal(depth.height_mm, -3.0)  # grey 0 is the low end


def test_an_unreadable_image_echoes_at_most_200_characters(tmp_path):
    folder = tmp_path / ("d" * 120)
    folder.mkdir()
    image = folder / ("x" * 200 + ".png")
    image.write_bytes(b"\x89PNG\r\n\x1a\n" + b"garbage " * 5000)
    args = ["cam", "depthmap", str(image), "--pixel-mm", "0.1", "--z-range-mm", "0:20"]
    args += ["--tool", "flat:10", "--plan", str(ROOT / "examples" / "cam_relief_part.toml")]
    args += ["--operation", "rough", "--out", str(tmp_path / "p.nc")]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 2
    line = result.output.strip()
    assert line.startswith("rcb: error: IMAGE = '/") and "cannot be read as an image" in line
    assert "…" in line and str(image) not in line
    assert len(line) < 2 * MAX_ECHO + 100


def test_an_input_error_echoes_at_most_200_characters_of_its_value():
    err = InputError("line 7", "F1" * 5_000_000, "two F words")
    assert str(err) == "line 7 = " + repr("F1" * 5_000_000)[: MAX_ECHO - 1] + "…: two F words"
    assert err.value == "F1" * 5_000_000  # kept whole for the caller
    assert str(InputError("n", 10**5000, "too long")) == "n = (a number too long to show): too long"
    assert str(InputError("k", "short", "ok")) == "k = 'short': ok"
