"""Constant-load milling setup and the tool-change rule (Tai, Tsai & Li 2023, §II.F, §III.A).

supervisor/constant_load.py and ``rcb milling setup`` (api/cli/milling.py); the test data are
tests/data/tai_end_milling_tests.csv, written by tests/data/make_tai_end_milling_tests.py.
The robust reference current at the tool's strength, the tool-change rule and the invariants
are in test_constant_load_strength.py.
"""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest
from constant_load_support import (
    CUTS,
    DATA,
    INPUT_ERROR,
    K1,
    TESTS_CSV,
    A,
    B,
    _csv_tests,
    _exact,
    _run,
)
from numpy.testing import assert_allclose

from models.errors import InputError, ModelDomainError
from supervisor.constant_load import constant_load_setup

# --------------------------------------------------------------------------------------------
# the setup, hand-computed on noise-free data


def test_setup_on_an_exact_plane_by_hand():
    feeds, currents, wears = _exact()
    setup = constant_load_setup(feeds, currents, wears)
    cal = setup.calibration
    assert_allclose([cal.idle_current_A, cal.slope_A_per_mm_min, cal.wear_coefficient_A_per_mm],
                    [A, B, K1], rtol=1e-9)  # fmt: skip
    # largest current: 0.1 + 1.4e-4·1000 + 0.2·0.2 = 0.28 A; Tai §III.A: I_ref = 0.85 × 0.28
    assert_allclose(setup.max_current_A, 0.28, rtol=1e-12)
    assert_allclose(setup.reference_current_A, 0.238, rtol=1e-12)
    assert setup.governed_by == "safety_factor" and setup.strength_current_A is None
    # Eq. 15 at VB = 0: (0.238 − 0.1)/1.4e-4 = 985.714 mm/min
    assert_allclose(setup.upper.feed_rate_mm_min, 985.714286, rtol=1e-7)
    # Eq. 15 at VB = 0.220 mm: (0.238 − 0.1 − 0.2·0.22)/1.4e-4 = 0.094/1.4e-4 = 671.429 mm/min;
    # no scatter, so no band: the lower limit is Eq. 15 at the worn end, wear at change 220 µm
    assert_allclose(setup.lower.feed_rate_mm_min, 671.428571, rtol=1e-7)
    assert_allclose(setup.lower.flank_wear_mm, 0.220, atol=1e-9)
    assert_allclose([setup.upper.band_mm_min, setup.lower.band_mm_min], 0.0, atol=1e-6)
    assert setup.wear_interval_mm == (0.180, 0.220)


def test_setup_options_by_hand():
    feeds, currents, wears = _exact()
    setup = constant_load_setup(
        feeds, currents, wears, safety_factor=0.9, max_current_A=0.25, wear_interval_mm=(0.1, 0.2)
    )
    # I_ref = 0.9 × 0.25 = 0.225 A; upper (0.225 − 0.1)/1.4e-4 = 892.857;
    # lower (0.125 − 0.2·0.2)/1.4e-4 = 607.143 mm/min
    assert_allclose(setup.reference_current_A, 0.225, rtol=1e-12)
    assert_allclose(setup.upper.feed_rate_mm_min, 892.857143, rtol=1e-7)
    assert_allclose(setup.lower.feed_rate_mm_min, 607.142857, rtol=1e-7)


def test_band_raises_the_lower_limit_and_keeps_the_wear_inside_the_interval():
    setup = constant_load_setup(*_csv_tests())
    cal, lower = setup.calibration, setup.lower
    nominal = (setup.reference_current_A - cal.idle_current_A
               - cal.wear_coefficient_A_per_mm * 0.220) / cal.slope_A_per_mm_min  # fmt: skip
    assert_allclose(lower.feed_rate_mm_min, nominal + lower.band_mm_min, rtol=1e-12)
    # the wear Eq. 15 gives at the lower limit, and its band up to the worn end
    k1 = cal.wear_coefficient_A_per_mm
    current_left = setup.reference_current_A - cal.idle_current_A
    wear = (current_left - cal.slope_A_per_mm_min * lower.feed_rate_mm_min) / k1
    assert_allclose(lower.flank_wear_mm, wear, rtol=1e-9)
    assert_allclose(lower.flank_wear_mm + lower.flank_wear_band_mm, 0.220, rtol=1e-12)
    # Tai Table 1: the wear when the feed reached the lower limit, 175-214 µm (mean 197 µm)
    assert 0.180 < lower.flank_wear_mm < 0.220
    assert 0.195 < lower.flank_wear_mm < 0.215
    # bands are k = 2 single-cut bands: at least 2·s/B from the scatter alone
    assert lower.band_mm_min >= 2 * cal.residual_sd_A / cal.slope_A_per_mm_min


# --------------------------------------------------------------------------------------------
# the paper's end-milling figures (acceptance), through the CLI


def test_acceptance_paper_end_milling_figures_through_the_cli():
    code, out, err = _run("setup", TESTS_CSV, "--json")
    assert code == 0, err
    data = json.loads(out)
    # Tai §III.A: reference current 0.85 × 0.28 A "set to 0.24 A"; upper limit 1000 mm/min,
    # lower limit 600 mm/min (§III.B: "0.24A ... 1000mm/min ... 600mm/min")
    assert data["reference_current_A"] == pytest.approx(0.24, abs=0.01)
    assert data["feed_rate_upper_mm_min"]["value"] == pytest.approx(1000, rel=0.05)
    assert data["feed_rate_lower_mm_min"]["value"] == pytest.approx(600, rel=0.05)
    assert data["max_current_A"] == pytest.approx(0.28, abs=0.002)
    assert data["governed_by"] == "safety_factor" and data["strength_current_A"] is None
    assert data["wear_interval_mm"] == [0.18, 0.22]
    assert data["calibration"]["kind"] == "tai_current_feed"
    assert data["calibration"]["n"] == 39
    assert 0 < data["feed_rate_upper_mm_min"]["band"] < 50
    assert data["feed_rate_lower_mm_min"]["band"] > 0


def test_installed_rcb_runs_the_setup():
    script = Path(sys.executable).parent / "rcb"
    if not script.is_file():
        pytest.skip("the rcb console script is not installed")
    done = subprocess.run(
        [str(script), "milling", "setup", str(TESTS_CSV), "--json"],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    lower = json.loads(done.stdout)["feed_rate_lower_mm_min"]["value"]
    assert lower == pytest.approx(600, rel=0.05)  # Tai §III.B: lower limit 600 mm/min


def test_cli_table_and_options():
    code, out, err = _run("setup", TESTS_CSV)
    assert code == 0, err
    assert "reference current" in out and "lower feed limit" in out
    code, out, err = _run(
        "setup", TESTS_CSV, "--json", "--safety-factor", "0.8", "--max-current-A", "0.3",
        "--wear-interval-um", "190, 210",
    )  # fmt: skip
    assert code == 0, err
    data = json.loads(out)
    assert data["reference_current_A"] == pytest.approx(0.24, rel=1e-12)  # 0.8 × 0.3 A
    assert data["wear_interval_mm"] == pytest.approx([0.19, 0.21])


def test_cli_accepts_wear_in_mm(tmp_path):
    feeds, currents, wears = _exact()
    lines = ["feed_rate_mm_min,spindle_current_A,flank_wear_mm"]
    lines += [f"{f},{i!r},{w}" for f, i, w in zip(feeds, currents, wears, strict=True)]
    path = tmp_path / "mm.csv"
    path.write_text("\n".join(lines) + "\n\n", encoding="utf-8")
    code, out, err = _run("setup", path, "--json")
    assert code == 0, err
    assert json.loads(out)["feed_rate_lower_mm_min"]["value"] == pytest.approx(671.428571)


# --------------------------------------------------------------------------------------------
# data the setup cannot use


@pytest.mark.parametrize(
    ("cuts", "kwargs", "field"),
    [
        (CUTS[:3], {}, "feed_rates_mm_min"),  # fewer than 4 cuts
        ([(600, 0.0), (800, 0.0), (1000, 0.0), (900, 0.0)], {}, "flank_wears_mm"),  # none worn
        (CUTS, {"safety_factor": 1.5}, "safety_factor"),
        (CUTS, {"safety_factor": 0.0}, "safety_factor"),
        (CUTS, {"wear_interval_mm": (0.22, 0.18)}, "wear_interval_mm"),  # reversed
        (CUTS, {"wear_interval_mm": (0.18,)}, "wear_interval_mm"),
        (CUTS, {"max_current_A": 0.1}, "reference_current_A"),  # 0.085 A <= A = 0.1 A
        (CUTS, {"max_current_A": -0.1}, "max_current_A"),
        # 0.238 − 0.1 − 0.2·0.7 < 0: a tool worn to 700 µm draws more than I_ref without cutting
        (CUTS, {"wear_interval_mm": (0.18, 0.7)}, "wear_interval_mm"),
        (CUTS, {"coverage_k": 0.0}, "coverage_k"),
    ],
)
def test_setup_refuses_unusable_data(cuts, kwargs, field):
    with pytest.raises(InputError) as err:
        constant_load_setup(*_exact(cuts), **kwargs)
    assert err.value.field == field


def test_setup_refuses_a_current_that_falls_with_wear():
    with pytest.raises(ModelDomainError) as err:
        constant_load_setup(*_exact(k1=-0.1))
    assert err.value.field == "wear_coefficient_A_per_mm"
    assert err.value.value == pytest.approx(-0.1)


def test_setup_refuses_bands_the_interval_cannot_hold():
    tests = _csv_tests()
    with pytest.raises(ModelDomainError) as err:  # ±10 µm band in a 5 µm interval
        constant_load_setup(*tests, wear_interval_mm=(0.215, 0.220))
    assert err.value.field == "wear_interval_mm" and "wider than the interval" in str(err.value)
    with pytest.raises(ModelDomainError) as err:  # worn end 5 µm: lower limit above upper
        constant_load_setup(*tests, wear_interval_mm=(0.0, 0.005))
    assert err.value.field == "wear_interval_mm" and "not below the upper" in str(err.value)


# --------------------------------------------------------------------------------------------
# the CLI error contract: exit 2, one line naming the field and value, no traceback


def _csv(tmp_path, text, name="t.csv"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


GOOD_ROWS = "".join(f"{f},{i!r},{w * 1000}\n" for f, i, w in zip(*_exact(), strict=True))


@pytest.mark.parametrize(
    ("text", "extra", "expected"),
    [
        (None, [], "TESTS.csv = '"),  # missing file
        ("feed_rate_mm_min,flank_wear_um\n600,0\n", [], "no column spindle_current_A"),
        ("feed_rate_mm_min,spindle_current_A,flank_wear_um\n" + GOOD_ROWS
         + "700,abc,0\n", [], "spindle_current_A[row 7] = 'abc': must be a number"),
        ("feed_rate_mm_min,spindle_current_A,flank_wear_um\n600,0.2,\n" + GOOD_ROWS, [],
         "flank_wear_um[row 1] = '': missing value"),
        ("feed_rate_mm_min,spindle_current_A,flank_wear_um\n-600,0.2,0\n" + GOOD_ROWS, [],
         "feed_rate_mm_min[row 1] = '-600': must be greater than 0"),
        ("feed_rate_mm_min,spindle_current_A,flank_wear_um,flank_wear_mm\n600,0.2,0,0\n", [],
         "ambiguous"),
        ("feed_rate_mm_min,spindle_current_A,flank_wear_um\n600,0.2\n", [],
         "TESTS.csv[row 1] = '600,0.2': has 2 cells"),
        ("", [], "is empty"),
        (None, ["--safety-factor", "1.5"], "--safety-factor = 1.5: must be in (0, 1]"),
        (None, ["--safety-factor", "0"], "--safety-factor = 0.0"),
        (None, ["--max-current-A", "-1"], "--max-current-A = -1.0"),
        (None, ["--safety-factor", "abc"], "--safety-factor"),
        (None, ["--wear-interval-um", "220,180"], "--wear-interval-um = '220,180': reversed"),
        (None, ["--wear-interval-um", "180"], "--wear-interval-um = '180'"),
        (None, ["--wear-interval-um", "180,x"], "--wear-interval-um = '180,x'"),
        (None, ["--strength-force-N", "100"],
         "--force-calibration: required with --strength-force-N"),
        (None, ["--strength-force-N", "100", "--force-calibration", "nope.toml"],
         "--force-calibration = 'nope.toml': no such file"),
        (None, ["--max-current-A", "0.1"], "reference_current_A = 0.085"),
    ],
)  # fmt: skip
def test_cli_errors_in_one_line(tmp_path, monkeypatch, text, extra, expected):
    monkeypatch.chdir(tmp_path)
    if text is None:
        path = TESTS_CSV if extra else tmp_path / "missing.csv"
    else:
        path = _csv(tmp_path, text)
    code, out, err = _run("setup", path, *extra)
    assert code == INPUT_ERROR, (out, err)
    assert len(err.strip().splitlines()) == 1, err
    assert err.startswith("rcb: error: ")
    assert expected in err
    assert "Traceback" not in err + out


# --------------------------------------------------------------------------------------------
# the test data


def test_generator_reproduces_the_csv_byte_for_byte():
    spec = importlib.util.spec_from_file_location(
        "make_tai_end_milling_tests", DATA / "make_tai_end_milling_tests.py"
    )
    assert spec is not None and spec.loader is not None
    generator = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(generator)
    assert generator.csv_text().encode("utf-8") == TESTS_CSV.read_bytes()
    # the plane of the generator is the paper's figures (its docstring): 0.24 A at 1000 mm/min
    # sharp; 0.238 A at 600 mm/min and 205 µm; 0.28 A at 1000 mm/min and 172.0 µm
    assert_allclose(generator.plane_current_A(1000, 0.0), 0.240, rtol=1e-12)
    assert_allclose(generator.plane_current_A(600, 205.0), 0.238, rtol=1e-12)
    assert_allclose(generator.plane_current_A(1000, 172.0), 0.280, atol=2e-5)
    assert_allclose(
        [generator.IDLE_CURRENT_A, generator.SLOPE_A_PER_MM_MIN,
         generator.WEAR_COEFFICIENT_A_PER_MM], [0.115844, 1.24156e-4, 0.232499], rtol=1e-5
    )  # fmt: skip
