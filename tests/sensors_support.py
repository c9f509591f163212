"""Helpers of the sensor conversion tests (tests/models/test_sensors.py, test_sensors_tai.py,
test_sensors_to_force.py): Monte Carlo sample size, an idle-load table, synthetic Kim & Jeon
calibration cuts, and Tai, Tsai & Li's plane derived from the paper's own numbers with its
constant-feed tests.
"""

from __future__ import annotations

import numpy as np

from models.sensors import IvesterSpindleLoadCalibration

MC_SAMPLES = 200_000

IDLE_TABLE = IvesterSpindleLoadCalibration(
    idle_speeds_rpm=(300.0, 600.0, 1200.0, 2400.0),
    idle_loads_V=(0.20, 0.25, 0.35, 0.55),
    u_idle_load_V=0.01,
    source="test idle table",
)


def _kim_jeon_150_mpm_data():
    """Synthetic calibration cuts on the paper's 150 mpm relation I = 5.762e-3 F + 3.206 A."""
    rng = np.random.default_rng(11)
    forces = np.linspace(40.0, 400.0, 15)
    currents = 5.762e-3 * forces + 3.206 + rng.normal(0.0, 0.02, forces.size)
    return currents, forces


# A, B, k1 from the paper's own end-milling numbers (§III.A), three points (f, VB, I):
#   sharp tool: I = 0.24 A at about 1000 mm/min (Fig. 4)                  (1000, 0,      0.240)
#   700 mm/min: current close to 0.24 A at VB = 167.3 µm (Fig. 7)         ( 700, 0.1673, 0.240)
#   600 mm/min: current 0.236 A at VB = 205.1 µm (Fig. 7)                 ( 600, 0.2051, 0.236)
# Eq. 14, I = A + B f + k1 VB, minus the first point:
#   (2) − (1): 0 = −300 B + 0.1673 k1          -> k1 = 1793.2 B
#   (3) − (1): −0.004 = −400 B + 0.2051 k1 = −400 B + 367.78 B = −32.22 B
#   B = 1.2416e-4 A/(mm/min); k1 = 0.22263 A/mm (2.2263e-4 A/µm); A = 0.24 − 0.12416 = 0.11584 A
TAI_B = 0.004 / (400 - 300 * 0.2051 / 0.1673)
TAI_K1 = 300 * TAI_B / 0.1673
TAI_A = 0.24 - 1000 * TAI_B


def _tai_tests(noise_A=0.0, seed=0):
    """Constant-feed tests on the paper-derived plane: sharp-tool feeds and worn tools."""
    rng = np.random.default_rng(seed)
    feeds, wears = [], []
    for f in (600.0, 700.0, 800.0, 900.0, 1000.0, 1100.0):  # sharp tools (Fig. 4)
        feeds += [f] * 3  # "three cutting tests were carried out for each cutting condition"
        wears += [0.0] * 3
    for f in (600.0, 700.0):  # wear tests at constant feed (Fig. 7)
        for vb in (0.05, 0.10, 0.15, 0.20):
            feeds.append(f)
            wears.append(vb)
    feeds, wears = np.array(feeds), np.array(wears)
    currents = TAI_A + TAI_B * feeds + TAI_K1 * wears + rng.normal(0.0, noise_A, feeds.size)
    return feeds, wears, currents
