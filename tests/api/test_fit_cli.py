"""Issue 18 item 11: ``rcb fit --life-to-wear`` fits tool life from flank-wear series.

The NASA Ames / UC Berkeley milling wear labels (tests/data, 16 cases, a 70 mm face mill with 6
inserts): per case the time VB first reaches 0.3 mm, then T = K · ap^a · fz^b with fz = feed/6.
Golden values: tests/models/test_fit_tool_life.py ``MEASURED_LIFE`` (cast iron n 8: K 27.82,
a −1.0318, b −0.0968, R² 0.8659, s 0.1788; steel n 7: K 1.2016, a −0.8543, b −0.6906), measured
once with numpy's lstsq on the same table.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from api.cli.main import app
from models.wear_life import life_at_wear, series_lives

DATA = Path(__file__).resolve().parents[1] / "data"
NASA_CSV = DATA / "nasa_milling_wear_labels.csv"
LIFE = [
    str(NASA_CSV),
    "--process=milling",
    "--life-to-wear=0.3",
    "--response=time",
    "--var=axial_depth_mm=DOC",
    "--var=feed_per_tooth_mm=feed/6",
    "--json",
]


@pytest.mark.parametrize(
    ("material", "n", "K", "a", "b", "r2", "s"),
    [
        ("1", 8, 27.82, -1.0318, -0.0968, 0.8659, 0.1788),  # cast iron
        ("2", 7, 1.2016, -0.8543, -0.6906, 0.7965, 0.2717),  # steel
    ],
)
def test_nasa_tool_life_per_material(runner, material, n, K, a, b, r2, s):
    result = runner.invoke(app, ["fit", *LIFE, f"--where=material={material}"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["n"] == n
    assert data["K"] == pytest.approx(K, rel=1e-3)
    assert data["exponents"]["axial_depth_mm"] == pytest.approx(a, abs=1e-4)
    assert data["exponents"]["feed_per_tooth_mm"] == pytest.approx(b, abs=1e-4)
    assert (data["r2"], data["s"]) == pytest.approx((r2, s), abs=1e-4)
    # case 6 (steel, 1.5 mm, 0.25 mm/rev) has one label, VB 0 at t 0: it never wears out
    assert data["life_to_wear"] == {
        "limit_mm": 0.3,
        "wear": "VB",
        "series": "case",
        "never": ["6"] if material == "2" else [],
    }
    if material == "2":
        assert "never reach the wear limit, left out: 6" in result.stderr


def test_life_interpolates_between_labels():
    # case 1: VB 0.29 at 29 min, 0.38 at 32 min; unlabelled times skipped
    nan = float("nan")
    assert life_at_wear([2, 29, 30, 32], [0.0, 0.29, nan, 0.38], 0.3) == pytest.approx(
        29 + 3 * 0.01 / 0.09
    )
    assert life_at_wear([6, 3], [0.30, 0.1], 0.3) == 6.0  # exactly at a label, any order
    assert life_at_wear([1, 2], [0.31, 0.5], 0.3) == 1.0  # worn at the first label
    assert life_at_wear([0, 5], [0.0, 0.2], 0.3) is None
    lives, never = series_lives(["a", "b", "a"], [0, 0, 10], [0.0, 0.1, 0.4], 0.3)
    assert lives == {"a": pytest.approx(7.5)} and never == ["b"]


def test_a_lower_limit_gives_shorter_lives(runner):
    lives = {}
    for limit in ("0.2", "0.3"):
        args = [a if not a.startswith("--life") else f"--life-to-wear={limit}" for a in LIFE]
        result = runner.invoke(app, ["fit", *args, "--where=material=1"])
        lives[limit] = json.loads(result.stdout)["K"]
    assert lives["0.2"] < lives["0.3"]


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--life-to-wear=0"], "--life-to-wear = 0.0: a flank wear [mm] > 0"),
        (["--life-to-wear=nan"], "--life-to-wear = nan"),
        (["--life-to-wear=9"], "--life-to-wear = 9.0: no case reaches it (VB at most"),
        (["--wear=VBX"], "--wear = 'VBX': no such column"),
        (["--series=tool"], "--series = 'tool': no such column"),
        (["--var=feed_per_tooth_mm=feed/0"], "the divisor must be > 0"),
        (["--var=feed_per_tooth_mm=feed/six"], "the divisor is no number"),
    ],
)
def test_bad_life_options_are_one_error_line(runner, extra, message):
    replaced = {e.partition("=")[0] + "=" + e.split("=")[1] for e in extra if e.count("=") == 2}
    base = [a for a in LIFE if not any(a.startswith(r) for r in replaced)]
    result = runner.invoke(app, ["fit", *base, *extra])
    assert result.exit_code == 2, result.output
    assert result.stderr.startswith("rcb: error: ") and message in result.stderr, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_wear_without_life_to_wear_is_refused(runner):
    args = [str(NASA_CSV), "--process=milling", "--response=time", "--var=axial_depth_mm=DOC"]
    result = runner.invoke(app, ["fit", *args, "--wear=VB"])
    assert result.exit_code == 2
    assert "--wear = 'VB': applies with --life-to-wear only" in result.stderr


def test_a_negative_wear_names_its_cell(runner, tmp_path):
    csv = tmp_path / "wear.csv"
    csv.write_text("case,time,VB,DOC\n1,0,0,1\n1,5,-0.1,1\n", encoding="utf-8")
    args = [str(csv), "--process=milling", "--life-to-wear=0.3", "--response=time"]
    result = runner.invoke(app, ["fit", *args, "--var=axial_depth_mm=DOC"])
    assert result.exit_code == 2
    assert "VB[row 2] = '-0.1': flank wear cannot be negative" in result.stderr


def test_a_short_row_is_named_as_short(runner, tmp_path):
    """A row of 2 fields under a header of 4 said ``F[row 6] = '': missing value``."""
    csv = tmp_path / "short.csv"
    rows = "".join(f"{n},0.{n},{n + 1}00,1\n" for n in range(1, 6))
    csv.write_text(f"V,f,F,DOC\n{rows}\n2,0.2\n", encoding="utf-8")
    args = [str(csv), "--process=turning", "--response=F", "--var=feed_mm_rev=f"]
    result = runner.invoke(app, ["fit", *args])
    assert result.exit_code == 2
    assert result.stderr.splitlines() == [
        "rcb: error: data file[row 6] = '2,0.2': has 2 fields where the header has 4"
    ]
