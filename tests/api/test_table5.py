"""`rcb predict` against the model columns of Ivester & Heigel Table 5.

Rows the paper computes inconsistently are left out (shared/seeds/README.md): step 1 row C
force (the model gives 739 ± 52 N, the table prints 758 ± 22), step 1 row AC2 (the model gives
Ra 5.26 µm against the printed 4.24, and 1880 N against 1778), and the step 4 force rows and
rows R/AC1 finish (CPGM32505; 13-24 % off).
"""

from __future__ import annotations

import json

import pytest
from numpy.testing import assert_allclose

from api.cli.main import app

# step, row, insert, d [mm], f [mm/rev], v [m/min], force N ± band, finish µm ± band
TABLE5 = [
    (1, "C", "CNMG432RN", 1.3, 0.25, 187, None, (2.34, 0.61)),
    (1, "R", "CNMG432RN", 3.0, 0.32, 200, (1867, 131), (3.12, 0.81)),
    (1, "AC1", "CNMG432RN", 2.6, 0.38, 200, (1874, 132), (3.91, 1.01)),
    (2, "C", "VCMR331", 0.5, 0.20, 256, (186, 57), (3.05, 0.49)),
    (2, "R", "VCMR331", 3.0, 0.10, 200, (574, 176), (1.71, 0.27)),
    (2, "AC1", "VCMR331", 3.0, 0.13, 200, (695, 213), (2.35, 0.38)),
    (3, "C", "VCMR331", 0.5, 0.20, 130, (160, 49), (3.03, 0.49)),
    (3, "R", "VCMR331", 3.0, 0.14, 130, (667, 204), (2.57, 0.41)),
    (3, "AC1", "VCMR331", 3.0, 0.18, 130, (802, 245), (3.49, 0.56)),
    (4, "C", "CPGM32505", 0.2, 0.10, 190, None, (1.80, 0.68)),
    (5, "C", "VPGR3305", 0.3, 0.10, 200, (66, 20), (2.61, 0.90)),
    (5, "R", "VPGR3305", 2.0, 0.05, 190, (234, 72), (1.30, 0.45)),
    (5, "AC1", "VPGR3305", 2.0, 0.08, 190, (333, 102), (2.18, 0.75)),
    (6, "C", "VPGR3305", 0.3, 0.10, 110, (58, 18), (2.67, 0.92)),
    (6, "R", "VPGR3305", 2.0, 0.05, 110, (207, 63), (1.33, 0.46)),
    (6, "AC1", "VPGR3305", 2.0, 0.08, 110, (292, 89), (2.22, 0.77)),
]


@pytest.mark.parametrize(
    ("step", "row", "insert", "d", "f", "v", "force", "finish"),
    TABLE5,
    ids=[f"step{r[0]}-{r[1]}" for r in TABLE5],
)
def test_predict_reproduces_table5(runner, step, row, insert, d, f, v, force, finish):
    args = ["predict", "--tool", insert, "--depth-mm", str(d), "--feed-mm-rev", str(f)]
    result = runner.invoke(app, [*args, "--speed-m-min", str(v), "--json"])
    assert result.exit_code == 0, result.output
    predicted = json.loads(result.stdout)["predicted"]
    # Ivester & Heigel Table 5, step {step} row {row}, "Model" columns
    if force is not None:
        assert_allclose(predicted["force_N"]["value"], force[0], rtol=0.02)
        assert_allclose(predicted["force_N"]["band"], force[1], rtol=0.06)
    assert_allclose(predicted["roughness_um"]["value"], finish[0], rtol=0.02)
    assert_allclose(predicted["roughness_um"]["band"], finish[1], rtol=0.06)


def test_step1_ac2_finish_is_the_papers_inconsistency(runner):
    """The paper prints Ra 4.24 µm for AC2; its own model gives about 5.3 µm (seeds README)."""
    args = ["predict", "--tool", "CNMG432RN", "--depth-mm", "2.1", "--feed-mm-rev", "0.48"]
    result = runner.invoke(app, [*args, "--speed-m-min", "200", "--json"])
    ra = json.loads(result.stdout)["predicted"]["roughness_um"]["value"]
    assert_allclose(ra, 5.26, rtol=0.01)
    assert ra > 4.0  # over the 4.0 µm limit of Table 4 step 1
