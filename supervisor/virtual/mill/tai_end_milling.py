r"""Tai, Tsai & Li (IEEE Access 2023): their constant-load end milling, read from its data file.

The numbers live in ``models/data/tai_end_milling.toml``, each with its section or figure.

S45C steel, a 2.0 mm two-flute uncoated carbide end mill, 10000 rpm, axial depth 0.2 mm,
radial depth 1.4 mm, down milling, passes of 150 mm (§II.E). The controller's parameters:
reference current 0.24 A (0.85 × 0.28 A), feed limits 1000 and 600 mm/min (§III.A), PI gains
``K_p = 160``, ``K_i = 0.006`` (§III.B), feed override updated at 50 Hz (§II.D), tool change
interval 180-220 µm of flank wear (§II.G).

The paper prints no ``A, B, k1``; three of its own points fix the plane of Eq. 14
(``I = A + B f + k1 VB``):

=====================================  ============  ========  =======
point                                  f [mm/min]    VB [mm]   I [A]
=====================================  ============  ========  =======
sharp tool at the reference (Fig. 4)   1000          0         0.240
700 mm/min "close to" 0.24 A (Fig. 7)  700           0.1673    0.240
600 mm/min reached 0.236 A (Fig. 7)    600           0.2051    0.236
=====================================  ============  ========  =======

Subtracting the first row: ``0.1673 k1 = 300 B`` and ``0.2051 k1 − 400 B = −0.004``, so
``B = 0.004/(400 − 300·0.2051/0.1673) = 1.2416e-4 A/(mm/min)``, ``k1 = 0.22263 A/mm``,
``A = 0.24 − 1000 B = 0.11584 A`` (the same derivation as ``tests/test_sensors.py``; the
currents are read in mA, as printed, so their difference is exact).

An inconsistency of the paper's numbers: on this plane the reference current 0.24 A at the
lower limit 600 mm/min means ``VB = (0.24 − A − 600 B)/k1 = 223 µm``, outside the
180-220 µm interval the limit was chosen for; the paper picked 600 mm/min from a reading of
0.236 A, not 0.24 A. :data:`TAI_LOWER_FEED_RATE_MM_MIN` is therefore computed the way the
paper prescribes (Eq. 15 at the reference current and the chosen tool-change wear), with
205.1 µm, the wear the paper's 600 mm/min test ended at ("in the middle of the wear range"):
632.2 mm/min.
"""

from __future__ import annotations

from typing import Any

from models import fields
from models.data import read_toml
from models.errors import InputError
from models.sensors import TaiCurrentFeedCalibration, tai_feed_rate_mm_min
from supervisor.virtual.mill.feed_limits import FeedLimits

_FILE = "tai_end_milling.toml"
_DATA = read_toml(_FILE)


def _value(table: str, key: str) -> float:
    """A number of the data file, by table and key; errors name the file and the field."""
    section: dict[str, Any] = dict(fields.mapping(_DATA, _FILE))
    for part in table.split("."):
        section = dict(fields.mapping(section[part], f"{_FILE}:{table}"))
    return fields.number(section[key], f"{_FILE}:{table}.{key}")


def _pair(table: str, key: str) -> tuple[float, float]:
    """Two numbers of the data file (an interval), by table and key."""
    path = f"{_FILE}:{table}.{key}"
    values = fields.number_list(fields.mapping(_DATA[table], path)[key], path)
    if len(values) != 2:
        raise InputError(path, values, "must be two numbers")
    return values[0], values[1]


def _plane() -> TaiCurrentFeedCalibration:
    """``A, B, k1`` through the three points of the module docstring."""
    f_sharp = _value("plane.sharp", "feed_rate_mm_min")
    i_sharp_A = _value("plane.sharp", "spindle_current_mA") / 1000.0
    f_same = _value("plane.same_current", "feed_rate_mm_min")
    vb_same = _value("plane.same_current", "flank_wear_mm")
    f_reached = _value("plane.reached", "feed_rate_mm_min")
    vb_reached = _value("plane.reached", "flank_wear_mm")
    drop_A = (
        _value("plane.sharp", "spindle_current_mA") - _value("plane.reached", "spindle_current_mA")
    ) / 1000.0
    slope = drop_A / ((f_sharp - f_reached) - (f_sharp - f_same) * vb_reached / vb_same)
    wear = (f_sharp - f_same) * slope / vb_same
    return TaiCurrentFeedCalibration(
        idle_current_A=i_sharp_A - f_sharp * slope,
        slope_A_per_mm_min=slope,
        wear_coefficient_A_per_mm=wear,
        source=fields.text(_DATA, "source", _FILE),
        reference=fields.text(_DATA, "reference", _FILE),
    )


#: ``I = A + B f + k1 VB`` of Tai et al.'s end milling, from three of the paper's points.
TAI_END_MILLING = _plane()

#: Reference spindle current [A] (Tai et al. §III.A: 0.85 × 0.28 A, printed as 0.24 A).
TAI_REFERENCE_CURRENT_A = _value("controller", "reference_current_A")

#: Tool-change interval of flank wear [mm] (Tai et al. §II.G: 180-220 µm).
TAI_TOOL_CHANGE_INTERVAL_MM = _pair("controller", "tool_change_interval_mm")

#: Flank wear at which the lower feed limit is set [mm] (Tai et al. §III.A, Fig. 7: 205.1 µm).
TAI_TOOL_CHANGE_WEAR_MM = _value("controller", "tool_change_wear_mm")

#: Upper feed limit [mm/min] (Tai et al. §III.A: a sharp tool draws 0.24 A at about 1000).
TAI_UPPER_FEED_RATE_MM_MIN = _value("controller", "upper_feed_rate_mm_min")

#: Lower feed limit [mm/min]: Eq. 15 at 0.24 A and 205.1 µm on :data:`TAI_END_MILLING`.
TAI_LOWER_FEED_RATE_MM_MIN = tai_feed_rate_mm_min(
    TAI_END_MILLING, TAI_REFERENCE_CURRENT_A, TAI_TOOL_CHANGE_WEAR_MM
).value

#: The paper's printed lower limit [mm/min] (§III.A), kept to show the inconsistency above.
TAI_PRINTED_LOWER_FEED_RATE_MM_MIN = _value("controller", "printed_lower_feed_rate_mm_min")

#: Feed limits of the end-milling edge-life simulation.
TAI_FEED_LIMITS = FeedLimits(TAI_LOWER_FEED_RATE_MM_MIN, TAI_UPPER_FEED_RATE_MM_MIN)

#: Wear per removed volume [mm/mm³] (:class:`~supervisor.virtual.mill.process.WearLaw`): Tai et
#: al. §III.D and Table 1, 197.26 µm on average after 2250 mm at 0.2 × 1.4 mm².
TAI_WEAR_RATE_MM_PER_MM3 = _value("wear", "flank_wear_at_change_mm") / (
    _value("wear", "path_length_mm")
    * _value("cut", "axial_depth_mm")
    * _value("cut", "radial_depth_mm")
)

#: Feed-override update period [s] (Tai et al. §II.D: 50 Hz).
TAI_SAMPLE_PERIOD_S = _value("controller", "sample_period_s")

#: Spindle speed [rpm], radial depth [mm], axial depth [mm], pass length [mm] (§II.E).
TAI_SPINDLE_RPM = _value("cut", "spindle_rpm")
TAI_RADIAL_DEPTH_MM = _value("cut", "radial_depth_mm")
TAI_AXIAL_DEPTH_MM = _value("cut", "axial_depth_mm")
TAI_PASS_LENGTH_MM = _value("cut", "pass_length_mm")
