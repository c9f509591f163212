"""How far apart are real contexts of one tool on one material? The AISI 12L14 roughness data.

The virtual fleet (``closed_loop.py --fleet``) draws each machine's ``ln K`` from the tool's
with a between-machine spread of 3 % (``--fleet-spread 0.03``). This script reads the one
real data set we hold that measures one tool on one material in several contexts:
``tests/data/aisi12l14_turning_roughness.csv`` (CC BY 4.0, DOI 10.5281/zenodo.17438392,
attribution in ``tests/data/ATTRIBUTION.md``): Ra [µm] of CNC turning over a central
composite design in cutting speed, feed and depth, on shafts of two diameters (D30, D50),
at three axial positions (chuck, middle, live centre), with a new and a worn insert.

For each insert state it fits, by least squares on logs,

    ln Ra = ln K + a·ln d + b·ln f + c·ln v + o_context              (Ivester & Heigel Eq. 6)

with one offset ``o`` per context (diameter x position, six: the hierarchical model's
per-context offset of ``docs/concepts/fleet.md``, here as fixed effects: 204 points per
context make each offset's own error about 0.02, small beside their spread) and prints:

- the power law's residual without the offsets (what one law for all contexts leaves),
- the offsets' standard deviation (the between-context spread of ``ln K``), and the same
  by diameter alone and by position alone,
- the residual with the offsets and the replicate scatter (the spread of ``ln Ra`` among the
  repeats of one cutting condition in one context): the measurement's own noise.

A figure as ``ln`` spread ``s`` is a relative spread of about ``s`` (``exp(s) - 1``). Run::

    .venv/bin/python benchmarks/real_spread.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

CSV = Path(__file__).resolve().parents[1] / "tests" / "data" / "aisi12l14_turning_roughness.csv"
#: The design's variables: the file's columns of depth [mm], feed [mm/rev], speed [m/min].
VARIABLES = ("d", "f", "Vc")
#: The virtual fleet's between-machine spread of ln K (closed_loop.py --fleet-spread default).
VIRTUAL_SPREAD = 0.03


def _read() -> pd.DataFrame:
    table = pd.read_csv(CSV)  # the diameter's header (5th column) is mis-encoded in the file
    table = table.rename(columns={table.columns[4]: "D"})
    table["context"] = table["D"] + " " + table["P"]
    return table


def _fit(table: pd.DataFrame, groups: str | None) -> tuple[np.ndarray, pd.Series]:
    """Least squares of ln Ra on the logs of the variables (+ one offset per group):
    the residuals and the groups' offsets (centred), empty without groups."""
    y = np.log(table["Ra"].to_numpy())
    columns = [np.log(table[name].to_numpy()) for name in VARIABLES]
    names: list[str] = []
    if groups is None:
        columns.append(np.ones(len(table)))
    else:
        names = sorted(table[groups].unique())
        columns += [(table[groups] == name).to_numpy(float) for name in names]
    design = np.column_stack(columns)
    coefficients, *_ = np.linalg.lstsq(design, y, rcond=None)
    offsets = pd.Series(coefficients[len(VARIABLES) :], index=names or None, dtype=float)
    return y - design @ coefficients, offsets - offsets.mean()


def _replicate_sd(table: pd.DataFrame) -> float:
    """The pooled sd of ln Ra among the repeats of one condition in one context."""
    logs = np.log(table["Ra"])
    keys = ["context", *VARIABLES]
    deviations = logs - logs.groupby([table[k] for k in keys]).transform("mean")
    groups = table.groupby(keys).ngroups
    return float(np.sqrt((deviations**2).sum() / (len(table) - groups)))


def _sd(values: np.ndarray | pd.Series, fitted: int) -> float:
    return float(np.sqrt(np.sum(np.square(values)) / (len(values) - fitted)))


def main() -> None:
    table = _read()
    print(f"{CSV.name}: {len(table)} points; virtual fleet's spread {VIRTUAL_SPREAD:.2f}")
    header = ("insert", "law alone", "contexts", "diameter", "position", "+offsets", "repeats")
    print("{:<7}{:>11}{:>10}{:>10}{:>10}{:>10}{:>9}".format(*header))
    for state, rows in table.groupby("VB", sort=False):
        alone, _ = _fit(rows, None)
        residual, offsets = _fit(rows, "context")
        _, by_diameter = _fit(rows, "D")
        _, by_position = _fit(rows, "P")
        figures = (
            _sd(alone, len(VARIABLES) + 1),
            _sd(offsets, 1),
            _sd(by_diameter, 1),
            _sd(by_position, 1),
            _sd(residual, len(VARIABLES) + len(offsets)),
            _replicate_sd(rows),
        )
        print("{:<7}{:>11.3f}{:>10.3f}{:>10.3f}{:>10.3f}{:>10.3f}{:>9.3f}".format(state, *figures))
        print("       offsets: " + ", ".join(f"{k} {v:+.3f}" for k, v in offsets.items()))
    print("(sd of ln Ra: the law's residual alone; the offsets' sd over the 6 contexts, the")
    print(" 2 diameters, the 3 positions; the residual with the context offsets; the repeats')")


if __name__ == "__main__":
    main()
