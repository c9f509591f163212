"""The quantities the supervisor predicts and constrains, with their units and sense.

Names carry their unit (DESIGN.md, "Contracts"). A ``max`` quantity has an allowable maximum
(force, roughness, power ...); a ``min`` quantity an allowable minimum (tool life).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Sense = Literal["max", "min"]


@dataclass(frozen=True)
class Quantity:
    """A constrained or predicted quantity.

    Parameters
    ----------
    name : str
        Field name with its unit, e.g. ``force_N``.
    unit : str
        Unit as printed in tables.
    sense : {"max", "min"}
        Whether a limit on it is a maximum or a minimum.
    description : str
        One line for tables and errors.
    """

    name: str
    unit: str
    sense: Sense
    description: str


#: Quantities an empirical power-law model may predict (Ivester & Heigel Eqs. 5, 6, 8).
MODEL_QUANTITIES: dict[str, Quantity] = {
    q.name: q
    for q in (
        Quantity("force_N", "N", "max", "cutting force"),
        Quantity("roughness_um", "µm", "max", "surface roughness Ra"),
        Quantity("tool_life_mm3", "mm³", "min", "volume one edge removes before the wear limit"),
        Quantity("spindle_current_A", "A", "max", "spindle motor current"),
    )
}

#: Quantities derived from the cutting parameters and the force model (machine limits).
DERIVED_QUANTITIES: dict[str, Quantity] = {
    q.name: q
    for q in (
        Quantity("power_kW", "kW", "max", "cutting power at the upper force band"),
        Quantity("torque_Nm", "N·m", "max", "spindle torque at the upper force band"),
        Quantity("spindle_rpm", "rpm", "max", "spindle speed"),
        Quantity("feed_rate_mm_min", "mm/min", "max", "feed rate"),
    )
}
