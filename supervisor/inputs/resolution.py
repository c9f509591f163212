"""The machine's resolution: the step in which its control takes each cutting parameter.

A setpoint is handed to a control, which takes each parameter in steps: ``[machine.resolution]``
of a plan file, one step per cutting parameter, in the parameter's unit. Defaults
(:data:`DEFAULT_RESOLUTION`):

- ``depth_mm``, ``axial_depth_mm``, ``radial_depth_mm``: 0.001 mm, the least input increment of
  metric controls in the common increment system (IS-B: Fanuc, Siemens, Haas), the step of a
  program's axis words [1]_;
- ``feed_mm_rev``: 0.0001 mm/rev, the finest feed per revolution a Fanuc lathe takes under G95
  in IS-B (``F0.0001``) [1]_, and what ``rcb gcode`` writes (4 decimals,
  :mod:`supervisor.gcode.numbers`);
- ``speed_m_min``: 1 m/min, constant surface speed under G96 is a whole ``S`` in m/min [1]_
  (``rcb gcode`` writes whole numbers);
- ``feed_per_tooth_mm``: 0.0001 mm; a feed per tooth is no program word (the control takes
  ``F = fz·z·n`` in mm/min), and tool makers' tables give it to 3 decimals at most.

A step is at least :data:`SMALLEST_STEP` (finer than any control, and the grid's step counts
stay exact in a float). The grid of a parameter is the multiples ``k·step`` within its bounds,
in decimal arithmetic (0.325 is 3250 steps of 0.0001 exactly); a plan whose bounds hold no
grid point is refused, naming the bound.

References
----------
.. [1] Fanuc Series 0i-TF operator's manual (B-64604EN), increment system, feed per
   revolution, constant surface speed control.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from decimal import Decimal
from functools import lru_cache

from models import fields
from models.kinematics import PARAMETERS
from supervisor.errors import PlanError

#: Step of each cutting parameter when the plan gives none (module docstring).
DEFAULT_RESOLUTION: Mapping[str, float] = {
    "depth_mm": 0.001,
    "feed_mm_rev": 0.0001,
    "speed_m_min": 1.0,
    "axial_depth_mm": 0.001,
    "radial_depth_mm": 0.001,
    "feed_per_tooth_mm": 0.0001,
}
#: The finest step a plan may give [the parameter's unit].
SMALLEST_STEP = 1e-9
_ALL = tuple(dict.fromkeys(p for params in PARAMETERS.values() for p in params))
assert set(_ALL) == set(DEFAULT_RESOLUTION)


def resolution_from_mapping(data: object, path: str) -> dict[str, float]:
    """The steps of ``[machine.resolution]`` (``data``; None: absent) over the defaults."""
    if data is None:
        return dict(DEFAULT_RESOLUTION)
    given = fields.number_table(data, path, _ALL, minimum=SMALLEST_STEP)
    return {**DEFAULT_RESOLUTION, **given}


@lru_cache(maxsize=4096)
def steps_within(low: float, high: float, step: float) -> tuple[int, int]:
    """``(k_low, k_high)``: the multiples ``k·step`` of the grid within ``[low, high]``.

    Decimal arithmetic on the numbers as written (their shortest repr), so that a bound on the
    grid is a grid point. ``k_low > k_high`` when the bounds hold no grid point.
    """
    size = Decimal(repr(step))
    k_low = math.ceil(Decimal(repr(low)) / size)
    k_high = math.floor(Decimal(repr(high)) / size)
    return k_low, k_high


@lru_cache(maxsize=4096)
def grid_value(k: int, step: float) -> float:
    """``k·step`` as the float nearest to the decimal product (on the grid as written)."""
    return float(k * Decimal(repr(step)))


def check_bounds(
    bounds: Mapping[str, tuple[float, float]], resolution: Mapping[str, float], path: str
) -> None:
    """Refuse bounds that hold no grid point of the machine's resolution (``path``: bounds).

    A parameter the bounds fix (``low == high``, Tai's 1000 rpm as 62.832 m/min) is the value
    the plan means: the setpoint keeps it (:mod:`supervisor.optimize.grid`), on the grid or not.
    """
    for param, (low, high) in bounds.items():
        if low == high:
            continue
        k_low, k_high = steps_within(low, high, resolution[param])
        if k_low > k_high:
            raise PlanError(
                f"{path}.{param}",
                [low, high],
                f"no multiple of machine.resolution.{param} = {resolution[param]:g} lies "
                "within the bounds: widen them or give a finer resolution",
            )
