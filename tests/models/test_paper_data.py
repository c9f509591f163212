"""Paper numbers kept as data (``models/data/*.toml``): sourced, shipped, and read unchanged."""

from __future__ import annotations

import fnmatch
import re
import tomllib
from importlib import resources
from pathlib import Path

import pytest

from supervisor.virtual.mill import case1, tai_end_milling

ROOT = Path(__file__).resolve().parents[2]
PAPER_FILES = ("tai_end_milling.toml", "kim_jeon_case1.toml", "kim_jeon_current_force.toml")
NUMBER = re.compile(r"^\s*\w+\s*=\s*[-+\d\[]")


@pytest.mark.parametrize("filename", PAPER_FILES)
def test_every_number_names_its_source(filename):
    """A number carries a comment, or sits in a table whose header carries one."""
    text = resources.files("models.data").joinpath(filename).read_text(encoding="utf-8")
    header_comment = True  # top-level keys: the file's opening comment is their source
    for line in text.splitlines():
        if line.startswith("["):
            header_comment = "#" in line
        elif NUMBER.match(line):
            assert "#" in line or header_comment, f"{filename}: no source for {line!r}"


def test_package_data_ships_every_data_file():
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    patterns = pyproject["tool"]["setuptools"]["package-data"]["models.data"]
    for path in (ROOT / "models" / "data").iterdir():
        if path.suffix != ".py" and path.is_file():
            assert any(fnmatch.fnmatch(path.name, p) for p in patterns), path.name


def test_tai_plane_is_the_papers_three_points_bit_for_bit():
    # Tai, Tsai & Li (IEEE Access 2023) §III.A, Figs. 4 and 7: the derivation in the module doc
    slope = 0.004 / (400.0 - 300.0 * 0.2051 / 0.1673)
    plane = tai_end_milling.TAI_END_MILLING
    assert plane.slope_A_per_mm_min == slope
    assert plane.wear_coefficient_A_per_mm == 300.0 * slope / 0.1673
    assert plane.idle_current_A == 0.240 - 1000.0 * slope
    assert tai_end_milling.TAI_TOOL_CHANGE_INTERVAL_MM == (0.180, 0.220)
    assert tai_end_milling.TAI_SAMPLE_PERIOD_S == 0.02


def test_case1_numbers_are_kim_and_jeons():
    # Kim & Jeon (Precision Engineering 2011) §5.1-5.2
    assert (case1.KIM_JEON_SPINDLE_RPM, case1.KIM_JEON_REFERENCE_FORCE_N) == (1500.0, 160.0)
    assert case1.KIM_JEON_INITIAL_FEED_MM_MIN == 60.0
    limits = case1.KIM_JEON_FEED_LIMITS
    assert (limits.lower_feed_rate_mm_min, limits.upper_feed_rate_mm_min) == (20.0, 240.0)
    setup = case1.case1_setup()
    assert setup.radial_depth_mm == 10.0
    assert setup.feed_drive_time_constant_s == 0.05
