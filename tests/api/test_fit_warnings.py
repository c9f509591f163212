"""``rcb fit`` warns, in one line each, of a poor fit and of a band reaching zero (issue 30).

Scattered forces (no trend in feed or speed) fit with R² (ln) far below 0.5 and a range band
wider than K; the fit is still printed and the exit code is 0. A clean power law gives no
warning.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from numpy.testing import assert_allclose

from api.cli.fit_checks import POOR_R2
from api.cli.main import app

#: Forces [N] with no trend in feed [mm/rev] or speed [m/min]: a poor fit.
SCATTERED = [
    (0.1, 100, 500),
    (0.2, 100, 120),
    (0.3, 100, 900),
    (0.1, 200, 300),
    (0.2, 200, 1000),
    (0.3, 200, 150),
    (0.15, 150, 700),
    (0.25, 150, 200),
]
ARGS = ["--response=force", "--var=feed_mm_rev=feed", "--var=speed_m_min=speed"]


def _csv(tmp_path: Path, rows: list[tuple[float, float, float]]) -> Path:
    path = tmp_path / "forces.csv"
    path.write_text("feed,speed,force\n" + "".join(f"{f},{v},{y}\n" for f, v, y in rows))
    return path


def test_scattered_data_warn_of_r2_and_band(runner, tmp_path):
    result = runner.invoke(
        app, ["fit", str(_csv(tmp_path, SCATTERED)), *ARGS, "--quantity=force_N", "--json"]
    )
    assert result.exit_code == 0, result.output
    fitted = json.loads(result.stdout)
    # R² of ln force on ln feed and ln speed, by numpy's least squares on the same rows
    f, v, y = (np.log(np.array(c, dtype=float)) for c in zip(*SCATTERED, strict=True))
    X = np.column_stack([np.ones(len(y)), f, v])
    residual = y - X @ np.linalg.lstsq(X, y, rcond=None)[0]
    r2 = 1 - residual @ residual / np.sum((y - y.mean()) ** 2)
    assert_allclose(fitted["r2"], r2, rtol=1e-9)
    assert_allclose(fitted["r2"], 0.0245, atol=5e-5)
    K, dK = fitted["K"], fitted["dK"]
    assert r2 < POOR_R2 and K - dK <= 0
    assert result.stderr.splitlines() == [
        f"rcb: warning: force_N: R² (ln) = {fitted['r2']:.3g} is below 0.5: a poor fit, the "
        "variables explain little of the scatter; check the columns, --where, or add variables",
        f"rcb: warning: force_N: the band's lower edge K − ΔK = {K - dK:.4g} is at or below zero "
        f"(K = {K:.4g}, ΔK = {dK:.4g}): the data scatter too widely for a band on K; a minimum "
        "such as tool life has no robust value",
    ]
    assert "Traceback" not in result.stderr


def test_the_table_is_printed_with_the_warnings(runner, tmp_path):
    result = runner.invoke(app, ["fit", str(_csv(tmp_path, SCATTERED)), *ARGS])
    assert result.exit_code == 0, result.output
    assert "R² (ln)" in result.stdout
    lines = result.stderr.splitlines()
    assert len(lines) == 2 and all(line.startswith("rcb: warning: force: ") for line in lines)


def test_a_clean_power_law_gives_no_warning(runner, tmp_path):
    rows = [
        (f, v, round(1800 * f**0.8 * v**-0.1 * (1 + 0.02 * (-1) ** i), 3))
        for i, (f, v) in enumerate((f, v) for f in (0.1, 0.2, 0.3) for v in (100, 150, 200))
    ]
    result = runner.invoke(app, ["fit", str(_csv(tmp_path, rows)), *ARGS, "--json"])
    assert result.exit_code == 0, result.output
    fitted = json.loads(result.stdout)
    assert fitted["r2"] > 0.99 and fitted["K"] > fitted["dK"]
    assert result.stderr == ""
