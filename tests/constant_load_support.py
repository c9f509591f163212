"""Helpers of the constant-load milling tests (tests/supervisor/test_constant_load.py,
test_constant_load_strength.py): the paper's test data, a round-number current plane with its
noise-free cuts, and ``rcb milling`` run in process.
"""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from api.cli.main import app
from api.cli.milling import read_tests

DATA = Path(__file__).resolve().parent / "data"
TESTS_CSV = DATA / "tai_end_milling_tests.csv"
INPUT_ERROR = 2

# A round-number plane I = A + B·f + k1·VB (Tai Eq. 14) for hand computation.
A, B, K1 = 0.100, 1.4e-4, 0.200  # A, A/(mm/min), A/mm
#: (feed [mm/min], flank wear [mm]): sharp tools at three feeds, wear tests at 600 and 1000.
CUTS = [(600, 0.0), (800, 0.0), (1000, 0.0), (600, 0.1), (600, 0.2), (1000, 0.2)]


def _exact(cuts=CUTS, a=A, b=B, k1=K1):
    feeds = [float(f) for f, _ in cuts]
    wears = [w for _, w in cuts]
    currents = [a + b * f + k1 * w for f, w in cuts]
    return feeds, currents, wears


def _csv_tests():
    return read_tests(TESTS_CSV)


def _run(*args):
    result = CliRunner().invoke(app, ["milling", *map(str, args)])
    return result.exit_code, result.stdout, result.stderr
