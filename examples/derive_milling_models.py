"""How the force model of examples/milling_demo_part.toml follows from Kim & Jeon and Tai et al.

Run: ``python examples/derive_milling_models.py``. Prints the fitted power law and the checks
against the papers' numbers; tests/api/test_milling_demo.py asserts the same numbers.

- Kim & Jeon (Precision Engineering 2011) Eq. 1, full immersion, two flutes: the mean and the
  oscillating part of F_y are ``Ks·ft·d/2`` and at most ``Ks·ft·h/(4π)·sin(2πd/h)·sqrt(1+Krt²)``
  (≈ ``Ks·ft·d/2·sqrt(1+Krt²)`` for d << h); their maximum per revolution is taken here as
  ``F_max ≈ Ks·ft·d·sqrt(1+Krt²)``, with §3's fits ``Ks = 800·tc^-0.197`` N/mm² and
  ``Krt = 0.163·tc^-0.353``, ``tc = 2·ft/π``. It gives 158 N at d = 3.0 mm, 70 mm/min and
  160 N at d = 1.5 mm, 190 mm/min (1500 rpm): the two steady states of their Fig. 5 (160 N).
- A power law ``F = K·ap·fz^b`` fitted in logarithms over the slot's bounds (ap 1-4 mm,
  fz 0.018-0.047 mm).
- Tai et al. (IEEE Access 2023) §III.A: the same sharp-tool spindle current slotting at
  600 mm/min as end milling at 70 % immersion at 1000 mm/min, so ``(1/0.7)^x = 1000/600`` for
  the radial-depth exponent x, and K per ``mm^x`` of radial depth is ``K_slot / 10^x``.
"""

from __future__ import annotations

import math

import numpy as np

SLOT_WIDTH_MM = 10.0


def kim_jeon_max_force_N(axial_depth_mm: float, feed_per_tooth_mm: float) -> float:
    """Maximum resultant force per revolution in a full-immersion slot (see the docstring)."""
    tc = 2.0 * feed_per_tooth_mm / math.pi
    ks = 800.0 * tc**-0.197
    krt = 0.163 * tc**-0.353
    return ks * feed_per_tooth_mm * axial_depth_mm * math.sqrt(1.0 + krt**2)


def slot_power_law() -> tuple[float, float, float, float]:
    """``(K, b, min, max)``: ``F = K·ap·fz^b`` and the least and largest ln misfit."""
    ap, fz = np.meshgrid(np.linspace(1.0, 4.0, 31), np.linspace(0.018, 0.047, 31))
    force = np.vectorize(kim_jeon_max_force_N)(ap, fz).ravel()
    y = np.log(force) - np.log(ap.ravel())  # ap exponent 1 (Eq. 1 is linear in d)
    design = np.column_stack([np.ones_like(y), np.log(fz.ravel())])
    (ln_k, b), *_ = np.linalg.lstsq(design, y, rcond=None)
    residual = y - design @ np.array([ln_k, b])
    return math.exp(ln_k), float(b), float(residual.min()), float(residual.max())


def radial_exponent() -> float:
    """Tai et al. §III.A: equal current slotting at 600 and end milling (ae 0.7 D) at 1000."""
    return math.log(1000.0 / 600.0) / math.log(1.0 / 0.7)


if __name__ == "__main__":
    k_slot, b, lo, hi = slot_power_law()
    x = radial_exponent()
    print(
        f"Kim & Jeon Fig. 5 checks: {kim_jeon_max_force_N(3.0, 70 / 3000):.1f} N, "
        f"{kim_jeon_max_force_N(1.5, 190 / 3000):.1f} N (paper: 160 N both)"
    )
    print(f"slot: F = {k_slot:.1f} · ap · fz^{b:.3f}  (ln misfit {lo:+.4f} .. {hi:+.4f})")
    print(f"radial exponent {x:.3f}; K = {k_slot / SLOT_WIDTH_MM**x:.2f} N per mm^(1+x)")
