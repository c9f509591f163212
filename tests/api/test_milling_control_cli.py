"""Issue 18 item 11: ``rcb milling control`` runs a feed controller on Kim & Jeon's Case 1.

Each controller holds 160 N within 5 % in every segment's steady state, at the feeds the force
model holds 160 N with (193.94 and 79.72 mm/min, tests/supervisor/test_mill_control.py), beside the
paper's 190 and 70 mm/min and its 300 N overshoot (Kim & Jeon, Precision Engineering 2011,
§5.1-5.2, Fig. 5c); ``--plot`` writes an SVG or PNG whole.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import pytest

from api.cli.main import app
from supervisor.virtual.mill import CONTROLLERS, run_case1

HOLDING_FEEDS = (193.94, 79.72, 193.94)


@pytest.mark.parametrize("controller", CONTROLLERS)
def test_each_controller_holds_the_force_and_reports_the_paper(runner, controller):
    result = runner.invoke(app, ["milling", "control", "--controller", controller, "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["reference_force_N"] == pytest.approx(160.0)
    segments = data["segments"]
    assert [s["depth_mm"] for s in segments] == [1.5, 3.0, 1.5]
    for segment, feed in zip(segments, HOLDING_FEEDS, strict=True):
        assert segment["deviation_max_rel"] < 0.05
        assert 0 <= segment["deviation_mean_rel"] <= segment["deviation_max_rel"]
        assert segment["feed_mean_steady_mm_min"] == pytest.approx(feed, rel=0.03)
    assert 280.0 < segments[1]["peak_force_N"] < 340.0  # paper: overshoot to 300 N
    assert [s["paper_feed_mm_min"] for s in segments] == [190.0, 70.0, 190.0]
    assert data["paper"]["overshoot_force_N"] == 300.0
    run = run_case1(controller, seed=0)  # the same run as the library's
    assert [s["deviation_mean_rel"] for s in segments] == [
        s.deviation_mean_rel for s in run.segments
    ]


def test_the_table_fits_80_columns(runner):
    result = runner.invoke(app, ["milling", "control", "--controller", "pi"], env={"COLUMNS": "80"})
    assert result.exit_code == 0, result.output
    assert max(len(line) for line in result.stdout.splitlines()) <= 80
    assert "190" in result.stdout and "70" in result.stdout and "300 N" in result.stdout


@pytest.mark.parametrize("suffix", [".svg", ".png"])
def test_plot_by_suffix_written_whole(runner, tmp_path, suffix):
    path = tmp_path / f"case1{suffix}"
    args = ["milling", "control", "--controller", "corrective", "--plot", str(path)]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    data = path.read_bytes()
    if suffix == ".png":
        assert data.startswith(b"\x89PNG\r\n\x1a\n")
    else:
        assert ET.fromstring(data).tag.endswith("svg")
        assert b"force [N]" in data or b"force" in data
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary file left
    again = tmp_path / f"again{suffix}"
    assert runner.invoke(app, [*args[:-1], str(again)]).exit_code == 0
    assert again.read_bytes() == data  # deterministic (no date in the file)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--controller", "pid"], "--controller = 'pid': one of: pi, fuzzy, corrective"),
        (["--controller", "pi", "--case", "kim-jeon-2"], "--case = 'kim-jeon-2': one of"),
        (["--controller", "pi", "--plot", "out.pdf"], "--plot = 'out.pdf': the suffix"),
        (["--controller", "pi", "--plot", "/no/such/dir/a.svg"], "the directory does not exist"),
        (["--controller", "pi", "--seed", "-1"], "--seed = -1"),
    ],
)
def test_bad_input_is_one_error_line(runner, args, message):
    result = runner.invoke(app, ["milling", "control", *args])
    assert result.exit_code == 2, result.output
    assert result.stderr.startswith("rcb: error: ") and message in result.stderr, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
