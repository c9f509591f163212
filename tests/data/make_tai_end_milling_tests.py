"""Write ``tai_end_milling_tests.csv``: constant-feed end-milling tests shaped on Tai et al.

Run ``python tests/data/make_tai_end_milling_tests.py`` to rewrite the CSV next to this file;
``tests/supervisor/test_constant_load.py`` checks that :func:`csv_text` reproduces it byte for
byte. Only the standard library is used, and the noise is drawn from
``random.Random(SEED).random()`` (the one generator method whose sequence Python promises to keep
across versions) by Box-Muller, so the file does not depend on a numpy version.

The plane ``I = A + B·f + k1·VB`` (Tai, Tsai & Li, IEEE Access 2023, Eq. 14)
----------------------------------------------------------------------------
The paper prints no A, B or k1 for end milling, only points read off its figures (§III.A):

- Fig. 4, sharp tool: "the feedrate corresponding to the initial spindle current of 0.24 A
  without any tool wear was about 1000 mm/min"                  -> (1000 mm/min, 0 µm, 0.240 A)
- Fig. 5/6: "the maximum spindle current that the worn tool can withstand was about 0.28 A";
  reference current 0.85 × 0.28 = 0.238 A
- Fig. 7: at 700 mm/min the current was "close to the reference current of 0.24 A" at
  167.3 µm; at 600 mm/min it "reached 0.236 A" at 205.1 µm.

``B`` and ``A`` are those of ``tests/sensors_support.py`` (the sharp line through 1000 mm/min,
0.24 A, with the slope the two Fig. 7 points give when read as 0.240 A and 0.236 A):

    B  = 0.004 / (400 − 300 · 0.2051/0.1673) = 1.24156e-4 A/(mm/min)
    A  = 0.24 − 1000 · B                     = 0.115844 A

``k1`` follows from the issue's acceptance figure, "at 600 mm/min the current reaches the
reference current (0.85 × 0.28 = 0.238 A) when the wear is 205 µm" (the paper prints 0.236 A
at 205.1 µm and calls 0.24 A the reference; the issue reads that point as the reference):

    k1 = (0.238 − A − 600 · B) / 0.205       = 0.232499 A/mm

On this plane a sharp tool draws 0.238 A at 983.9 mm/min (the paper's "about 1000"), and the
Fig. 7 point at 700 mm/min, 167.3 µm draws 0.2417 A ("close to 0.24 A").

The tests (rows of the CSV)
---------------------------
- ``sharp``: new tools (VB = 0) at 600, 700, ..., 1100 mm/min, three cuts each (Fig. 4: "Three
  cutting tests were carried out for each cutting condition").
- ``wear@1000``, ``wear@900``, ``wear@800``: constant-feed wear tests of Fig. 5; the 1000 mm/min
  tool is stopped at 172.0 µm, where its current reaches 0.280 A, the largest current the tool
  withstood (the paper's tool chipped just after, at 0.298 A, Fig. 6).
- ``wear@700``, ``wear@600``: the wear tests of Fig. 7, ending at 167.3 µm (700 mm/min) and
  205.0 µm (600 mm/min, where the current reaches the reference 0.238 A).

Each current is the plane's value plus Gaussian noise of standard deviation 1 mA (the paper's
constant-load average was 0.239 A against 0.240 A set, §III.B) and is written to 0.1 mA; feed
rates are whole mm/min and flank wear is in µm to 0.1 µm, as the paper prints it.
"""

from __future__ import annotations

import math
import random
from pathlib import Path

#: Seed of the current noise (the paper's year).
SEED = 2023
#: Standard deviation of the current noise [A].
NOISE_SD_A = 0.001

#: Eq. 14 plane (derivation in the module docstring).
SLOPE_A_PER_MM_MIN = 0.004 / (400.0 - 300.0 * 0.2051 / 0.1673)
IDLE_CURRENT_A = 0.24 - 1000.0 * SLOPE_A_PER_MM_MIN
REFERENCE_CURRENT_A = 0.85 * 0.28
WEAR_COEFFICIENT_A_PER_MM = (
    REFERENCE_CURRENT_A - IDLE_CURRENT_A - 600.0 * SLOPE_A_PER_MM_MIN
) / 0.205

#: (label, feed rate [mm/min], flank wears [µm]) of each test series.
SERIES: tuple[tuple[str, float, tuple[float, ...]], ...] = (
    *(("sharp", f, (0.0, 0.0, 0.0)) for f in (600.0, 700.0, 800.0, 900.0, 1000.0, 1100.0)),
    ("wear@1000", 1000.0, (40.0, 80.0, 120.0, 160.0, 172.0)),
    ("wear@900", 900.0, (50.0, 100.0, 150.0, 200.0)),
    ("wear@800", 800.0, (50.0, 100.0, 150.0, 200.0)),
    ("wear@700", 700.0, (40.0, 80.0, 120.0, 167.3)),
    ("wear@600", 600.0, (50.0, 100.0, 150.0, 205.0)),
)

HEADER = "test,feed_rate_mm_min,flank_wear_um,spindle_current_A"
CSV_PATH = Path(__file__).with_name("tai_end_milling_tests.csv")


def plane_current_A(feed_rate_mm_min: float, flank_wear_um: float) -> float:
    """Noise-free spindle current of the plane [A] (Tai et al. Eq. 14, VB in µm here)."""
    return (
        IDLE_CURRENT_A
        + SLOPE_A_PER_MM_MIN * feed_rate_mm_min
        + WEAR_COEFFICIENT_A_PER_MM * flank_wear_um / 1000.0
    )


def _normal(rng: random.Random) -> float:
    """One standard normal deviate by Box-Muller from two ``random()`` draws."""
    u1 = 1.0 - rng.random()  # in (0, 1]: log is finite
    u2 = rng.random()
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)


def csv_text() -> str:
    """The CSV file's text: header and one line per cut, ``\\n`` line ends."""
    rng = random.Random(SEED)
    lines = [HEADER]
    for label, feed, wears in SERIES:
        for wear in wears:
            current = plane_current_A(feed, wear) + NOISE_SD_A * _normal(rng)
            lines.append(f"{label},{feed:.0f},{wear:.1f},{current:.4f}")
    return "\n".join(lines) + "\n"


def main() -> None:
    """Rewrite the CSV next to this file."""
    CSV_PATH.write_bytes(csv_text().encode("utf-8"))


if __name__ == "__main__":
    main()
