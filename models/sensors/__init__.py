r"""Sensor conversions: spindle load or spindle current to cutting force, current to feed rate.

Each conversion is a pure function citing its paper's equation, with the uncertainty of the
result propagated to first order (GUM, JCGM 100:2008 Eq. 13):
:math:`u_y^2 = \sum_i (\partial f/\partial x_i\, u_i)^2 + 2\sum_{i<j} \partial_i f\,
\partial_j f\, u(x_i, x_j)`. Each conversion returns a :class:`Converted` ``(value,
uncertainty)``; each calibration is a frozen dataclass with its provenance.

- Ivester & Heigel (NIST), Eqs. 1-4: spindle load signal [V] → cutting force [N] on a lathe,
  :func:`ivester_force_N` (and its inverse :func:`ivester_load_V`).
- Kim & Jeon (Precision Engineering 2011), §6: RMS of the three phase currents
  (:func:`kim_jeon_rms_current_A`) and a linear current → force relation per feed rate
  (:func:`fit_linear_calibration`, :func:`linear_current_force_N`,
  :func:`feed_dependent_force_N`).
- Tai, Tsai & Li (IEEE Access 2023), Eqs. 13-15: spindle current = A + B·feed + k1·VB
  (:func:`fit_tai_calibration`, :func:`tai_spindle_current_A`) and its inversion for the
  feed rate (:func:`tai_feed_rate_mm_min`).

:func:`to_force` is the one entry point for a part report: a raw ``spindle_load_V`` or
``spindle_current_A`` with its expanded uncertainty → ``force_N`` with its expanded
uncertainty.

One module per concern: :mod:`~models.sensors.converted` (:class:`Converted`),
:mod:`~models.sensors.least_squares` (the fits' least squares and covariances), one per paper
(:mod:`~models.sensors.ivester`, :mod:`~models.sensors.kim_jeon` and
:mod:`~models.sensors.kim_jeon_feed`, :mod:`~models.sensors.tai`),
:mod:`~models.sensors.convert` (:func:`to_force`) and :mod:`~models.sensors.mapping` (plan-file
readers and writers); checked numbers come from :mod:`models.fields`. Every public name is
re-exported here.

Uncertainty conventions
-----------------------
The pure functions take and return *standard* uncertainties ``u`` (1σ); calibrations store
standard uncertainties (a fit's standard errors and covariance; Ivester & Heigel's ±2s
``Δm`` halved). First-order propagation is linear in the uncertainties, so inputs at a common
coverage factor give a result at that coverage; :func:`to_force` takes expanded uncertainties
(``coverage_k = 2``, the ±2σ of part reports, Ivester & Heigel Fig. 4), converts them to
standard ones, combines them with the calibration's and returns ``k·u``.

Plan-file format
----------------
Calibrations live in a table of named calibrations, each with a ``kind``; every field is in
the unit its name carries; ``source`` is required, ``reference``, ``date`` and ``notes`` are
optional provenance; every uncertainty ``u_*`` is a standard uncertainty (1σ) and
``corr_*`` a correlation coefficient::

    [machine.calibrations.spindle_load]
    kind = "ivester_spindle_load"            # Ivester & Heigel Eqs. 1-4
    source = "NIST lathe, dynamometer vs spindle load"
    # optional; defaults from the paper (Eqs. 1-2; Δm = ±0.21 at 2s, read as N·m/V):
    m_low_N_mm_per_V = 2.19e5                # Eq. 1, speed <= corner_speed_rad_s
    m_coefficient = 1.39e8                   # Eq. 2: m = m_coefficient · speed_rad_s^m_exponent
    m_exponent = -1.52
    corner_speed_rad_s = 70.2
    u_m_N_mm_per_V = 210.0
    # optional idle load measured without cutting (linear in speed, no extrapolation):
    idle_speeds_rpm = [300, 600, 1200, 2400]
    idle_loads_V = [0.20, 0.25, 0.35, 0.55]
    u_idle_load_V = 0.01

    [machine.calibrations.spindle_current]
    kind = "linear_current"                  # force_N = offset_N + slope_N_per_A · current_A
    source = "fit of 12 dynamometer cuts, 2024-05-02"
    offset_N = -556.4
    slope_N_per_A = 173.5
    u_offset_N = 4.1                         # optional, default 0
    u_slope_N_per_A = 0.9                    # optional, default 0
    corr_offset_slope = -0.97                # optional, default 0
    residual_sd_N = 3.2                      # optional, default 0
    n = 12                                   # optional: calibration points (0 = unknown)
    spindle_speed_rpm = 4500                 # optional: valid only at this speed ...
    speed_tolerance_rel = 0.05               # ... within this relative tolerance
    feed_rate_mm_min = 150                   # optional: the feed rate it was fitted at

    [machine.calibrations.spindle_current_by_feed]
    kind = "linear_current_by_feed"          # Kim & Jeon §6.2.3: one line per feed rate
    source = "Kim & Jeon (2011) §6.2.3"
    spindle_speed_rpm = 4500                 # optional, as above (speed_tolerance_rel too)
    points = [                               # >= 2, feed rates increasing; fields as above
      { feed_rate_mm_min = 150, offset_N = -556.4, slope_N_per_A = 173.55 },
      { feed_rate_mm_min = 300, offset_N = -591.4, slope_N_per_A = 167.20 },
    ]

    [machine.calibrations.milling_current]
    kind = "tai_current_feed"                # Tai et al. Eq. 14: I = A + B·f + k1·VB
    source = "constant-feed wear tests"
    idle_current_A = 0.116                   # A
    slope_A_per_mm_min = 1.24e-4             # B
    wear_coefficient_A_per_mm = 0.223        # k1
    # optional: u_idle_current_A, u_slope_A_per_mm_min, u_wear_coefficient_A_per_mm,
    # corr_idle_slope, corr_idle_wear, corr_slope_wear, residual_sd_A, n

Read them with :func:`calibrations_from_mapping` (the whole table) or
:func:`calibration_from_mapping` (one); :func:`calibration_to_mapping` writes one back.

References
----------
.. [1] Ivester & Heigel, Smart Machining Systems: Robust Optimization and Adaptive Control
   Optimization for Turning Operations (NIST), "Spindle Torque Model": Eqs. 1-4.
.. [2] Kim & Jeon, Fuzzy-logic control of cutting forces in CNC milling processes using motor
   currents as indirect force sensors, Precision Engineering (2011), §6, §6.2.3, §7.
.. [3] Tai, Tsai & Li, Establishment of Real-Time Adaptive Control Strategy for Milling
   Parameters, IEEE Access (2023), Eqs. 12-15 and §III.A.
.. [4] JCGM 100:2008 (GUM), Eqs. 10 and 13; Taylor & Kuyatt, NIST Technical Note 1297 (1994).
"""

from __future__ import annotations

from models.sensors.convert import RAW_QUANTITIES, Calibration, RawQuantity, to_force
from models.sensors.converted import Converted
from models.sensors.ivester import (
    IVESTER_SPINDLE_LOAD,
    IvesterSpindleLoadCalibration,
    ivester_force_N,
    ivester_idle_load_V,
    ivester_load_V,
    ivester_ratio_N_mm_per_V,
    ivester_spindle_torque_Nm,
    rpm_to_rad_s,
)
from models.sensors.kim_jeon import (
    LinearCurrentCalibration,
    calibration_from_current_relation,
    fit_linear_calibration,
    kim_jeon_rms_current_A,
    linear_current_force_N,
)
from models.sensors.kim_jeon_feed import (
    KIM_JEON_SPINDLE_FMAX_4500RPM,
    FeedDependentCurrentCalibration,
    feed_dependent_force_N,
)
from models.sensors.mapping import (
    CALIBRATION_KINDS,
    calibration_from_mapping,
    calibration_to_mapping,
    calibrations_from_mapping,
    feed_dependent_calibration_from_mapping,
    ivester_calibration_from_mapping,
    linear_current_calibration_from_mapping,
    tai_calibration_from_mapping,
)
from models.sensors.tai import (
    TaiCurrentFeedCalibration,
    fit_tai_calibration,
    tai_feed_rate_mm_min,
    tai_reference_current_A,
    tai_spindle_current_A,
)

__all__ = [
    "CALIBRATION_KINDS",
    "IVESTER_SPINDLE_LOAD",
    "KIM_JEON_SPINDLE_FMAX_4500RPM",
    "RAW_QUANTITIES",
    "Calibration",
    "Converted",
    "FeedDependentCurrentCalibration",
    "IvesterSpindleLoadCalibration",
    "LinearCurrentCalibration",
    "RawQuantity",
    "TaiCurrentFeedCalibration",
    "calibration_from_current_relation",
    "calibration_from_mapping",
    "calibration_to_mapping",
    "calibrations_from_mapping",
    "feed_dependent_calibration_from_mapping",
    "feed_dependent_force_N",
    "fit_linear_calibration",
    "fit_tai_calibration",
    "ivester_calibration_from_mapping",
    "ivester_force_N",
    "ivester_idle_load_V",
    "ivester_load_V",
    "ivester_ratio_N_mm_per_V",
    "ivester_spindle_torque_Nm",
    "kim_jeon_rms_current_A",
    "linear_current_calibration_from_mapping",
    "linear_current_force_N",
    "rpm_to_rad_s",
    "tai_calibration_from_mapping",
    "tai_feed_rate_mm_min",
    "tai_reference_current_A",
    "tai_spindle_current_A",
    "to_force",
]
