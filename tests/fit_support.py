"""Helpers of the fitting tests (tests/models/test_fit*.py): the real data sets of
``tests/data/ATTRIBUTION.md`` read and fitted (AISI 12L14 roughness, NASA milling tool life),
an independent least-squares fit to check against, and ``rcb fit`` run in process.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import typer
from typer.testing import CliRunner

from api.cli.fit import fit
from models.fit import FitResult, fit_power_law
from models.wear_life import series_lives

DATA = Path(__file__).resolve().parent / "data"
ROUGHNESS_CSV = DATA / "aisi12l14_turning_roughness.csv"
NASA_CSV = DATA / "nasa_milling_wear_labels.csv"

#: Turning variables and the roughness file's columns for them.
TURNING_COLUMNS = {"depth_mm": "d", "feed_mm_rev": "f", "speed_m_min": "Vc"}
VAR_ARGS = [f"--var={name}={column}" for name, column in TURNING_COLUMNS.items()]

#: ISO 3685 flank-wear criterion for the tool-life fit [mm].
VB_LIMIT_MM = 0.3
#: NASA mill: a 70 mm face mill with 6 KC710 inserts (Goebel & Agogino, "Documentation for
#: Mill Data Set"), so feed per tooth = feed per revolution / 6.
NASA_INSERTS = 6

INPUT_ERROR = 2


@functools.cache
def roughness() -> pd.DataFrame:
    """The roughness set; the mis-encoded diameter header (5th column) renamed ``D``."""
    table = pd.read_csv(ROUGHNESS_CSV)
    return table.rename(columns={table.columns[4]: "D"})


def turning_fit(table: pd.DataFrame, band: Any = "range", k: float = 2.0) -> FitResult:
    return fit_power_law(
        table["Ra"].to_numpy(),
        {name: table[column].to_numpy() for name, column in TURNING_COLUMNS.items()},
        band=band,
        k=k,
    )


def ra(vb: str) -> pd.DataFrame:
    table = roughness()
    return table[table["VB"] == vb]


def time_to_wear(labels: pd.DataFrame, limit_mm: float = VB_LIMIT_MM) -> tuple[pd.DataFrame, list]:
    """Per case, the time at which VB first reaches ``limit_mm`` (:func:`models.wear_life.
    series_lives`: linear between labelled points, rows without VB skipped). Returns the cases
    that reach it (``case, DOC, feed, material, time_min``) and the case numbers that never do.
    """
    lives, never = series_lives(labels["case"].tolist(), labels["time"], labels["VB"], limit_mm)
    first = labels.groupby("case").first()
    reached = [
        {
            "case": int(case),
            "DOC": first.loc[case, "DOC"],
            "feed": first.loc[case, "feed"],
            "material": int(first.loc[case, "material"]),
            "time_min": life,
        }
        for case, life in lives.items()
    ]
    return pd.DataFrame(reached), [int(case) for case in never]


@functools.cache
def tool_life_table() -> pd.DataFrame:
    table, _ = time_to_wear(pd.read_csv(NASA_CSV))
    table["fz_mm"] = table["feed"] / NASA_INSERTS
    return table


def life_fit(table: pd.DataFrame, band: Any = "range") -> FitResult:
    """Milling tool life: DOC -> ``axial_depth_mm``, feed/6 -> ``feed_per_tooth_mm``."""
    return fit_power_law(
        table["time_min"].to_numpy(),
        {
            "axial_depth_mm": table["DOC"].to_numpy(),
            "feed_per_tooth_mm": table["fz_mm"].to_numpy(),
        },
        band=band,
    )


def independent_fit(
    y: np.ndarray, columns: Sequence[np.ndarray]
) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """``np.linalg.lstsq`` on the log design; covariance by the textbook ``s² (XᵀX)⁻¹``."""
    X = np.column_stack([np.ones(len(y)), *(np.log(c) for c in columns)])
    beta, *_ = np.linalg.lstsq(X, np.log(y), rcond=None)
    residuals = np.log(y) - X @ beta
    s2 = residuals @ residuals / (len(y) - X.shape[1])
    return beta, s2 * np.linalg.inv(X.T @ X), math.sqrt(s2), residuals


def _app() -> typer.Typer:
    app = typer.Typer(add_completion=False, pretty_exceptions_enable=False)

    @app.callback()
    def root() -> None:
        """rcb with only the fit command (api/cli/main.py registers fit in the real one)."""

    app.command()(fit)
    return app


APP = _app()


def run(args: Sequence[object]) -> tuple[int, str, str]:
    result = CliRunner().invoke(APP, ["fit", *map(str, args)])
    exc = result.exception
    assert exc is None or isinstance(exc, SystemExit), f"uncaught {exc!r}"
    return result.exit_code, result.stdout, result.stderr
