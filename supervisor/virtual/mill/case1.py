"""Kim & Jeon's Case 1 on the virtual mill, under each of the three feed controllers.

The numbers live in ``models/data/kim_jeon_case1.toml``, each with its section. Those of Kim &
Jeon's §5.1 simulation: Al6061-T6, a two-flute 10 mm end mill in full immersion, 1500 rpm,
reference force 160 N (maximum resultant per revolution), initial feed 60 mpm (mm/min), depth
1.5 → 3.0 → 1.5 mm (:func:`kim_jeon_case1_workpiece`); the upper feed limit 240 mpm of their
experiment (§5.2). Chosen where the paper is silent:

- lower feed limit 20 mm/min (a quarter of the feed that holds 160 N at 3 mm);
- spindle current ``I = 3.206 + 5.762e-3 F`` A (§6.2.3, 150 mpm), read with 5 Hz bandwidth
  (§6.2: "< 5 Hz") and noise 0.005 A (0.87 N, 0.5 % of 160 N);
- feed drive: first-order lag of 50 ms (§4.2 designs the servo for a fast rise without
  overshoot; its Eqs. 2-3 as printed do not fix a time constant);
- no tool wear (an aluminium cut of 55 mm).

Each controller reads its paper's signal at its paper's rate: Tai et al.'s PI the spindle
current every 20 ms, with the gains rescaled to this plant (:func:`tai_pi_gains_for` at
1.5 mm and 160 N); Kim & Jeon's fuzzy controller and Borangiu et al.'s corrective actions
the force converted from the current, once per revolution (40 ms).
"""

from __future__ import annotations

import numpy as np

from models import fields
from models.data import read_toml
from models.errors import InputError
from models.milling_force import KimJeonForceModel, feed_for_force_mm_min
from supervisor.virtual.mill.controllers.base import FeedController
from supervisor.virtual.mill.controllers.corrective import BorangiuCorrectiveController
from supervisor.virtual.mill.controllers.fuzzy import KimJeonFuzzyController
from supervisor.virtual.mill.controllers.pi import TaiPIController, tai_pi_gains_for
from supervisor.virtual.mill.feed_limits import FeedLimits
from supervisor.virtual.mill.process import (
    CurrentSensor,
    ForceCurrentMill,
    StepWorkpiece,
)
from supervisor.virtual.mill.run import MillRun, MillSetup, simulate

_FILE = "kim_jeon_case1.toml"
_DATA = read_toml(_FILE)


def _value(key: str) -> float:
    """A number of the data file; errors name the file and the field."""
    return fields.number(_DATA[key], f"{_FILE}:{key}")


#: Kim & Jeon §5.1: spindle speed [rpm], reference force [N], initial feed [mm/min].
KIM_JEON_SPINDLE_RPM = _value("spindle_rpm")
KIM_JEON_REFERENCE_FORCE_N = _value("reference_force_N")
KIM_JEON_INITIAL_FEED_MM_MIN = _value("initial_feed_rate_mm_min")

#: Feed limits [mm/min]: 240 from Kim & Jeon §5.2; 20 chosen (see the module).
KIM_JEON_FEED_LIMITS = FeedLimits(
    _value("lower_feed_rate_mm_min"), _value("upper_feed_rate_mm_min")
)

#: The three controllers, by name.
CONTROLLERS = ("pi", "fuzzy", "corrective")

#: Tai et al.'s sample period [s] (50 Hz, §II.D), used by the PI here too.
PI_SAMPLE_PERIOD_S = _value("pi_sample_period_s")


def kim_jeon_case1_workpiece() -> StepWorkpiece:
    """Kim & Jeon Case 1: depth 1.5 → 3.0 → 1.5 mm (§5.1, Fig. 5a).

    The paper gives the depths and the times of the steps in its simulation (2.7 s and
    5.3 s), not the lengths. The lengths chosen, 20, 15 and 20 mm, give each segment several
    seconds at the feeds that hold 160 N (about 190 and 80 mm/min), so that each controller
    settles and the last third of each segment is a steady state.
    """
    segments = fields.mapping(_DATA["workpiece"], f"{_FILE}:workpiece")
    lengths = fields.number_list(segments["lengths_mm"], f"{_FILE}:workpiece.lengths_mm")
    depths = fields.number_list(segments["depths_mm"], f"{_FILE}:workpiece.depths_mm")
    return StepWorkpiece(tuple(zip(lengths, depths, strict=True)))


def case1_setup(*, sample_period_s: float | None = None) -> MillSetup:
    """The virtual mill of Case 1 (see the module for the numbers and their sources).

    Parameters
    ----------
    sample_period_s : float, optional
        Controller period [s]; None for one revolution (40 ms at 1500 rpm).
    """
    return MillSetup(
        process=ForceCurrentMill(KimJeonForceModel()),
        spindle_rpm=KIM_JEON_SPINDLE_RPM,
        radial_depth_mm=_value("radial_depth_mm"),
        sensor=CurrentSensor(
            noise_sd_A=_value("sensor_noise_sd_A"), bandwidth_Hz=_value("sensor_bandwidth_Hz")
        ),
        feed_drive_time_constant_s=_value("feed_drive_time_constant_s"),
        sample_period_s=sample_period_s,
    )


def case1_current_per_feed_A_per_mm_min(depth_mm: float = 1.5) -> float:
    """``∂I/∂f`` of the Case-1 mill where it holds 160 N at ``depth_mm`` [A/(mm/min)].

    Central difference of ``s·F_max(f)`` at ±0.1 % of the feed.
    """
    mill = ForceCurrentMill(KimJeonForceModel())
    model = mill.force_model
    feed = feed_for_force_mm_min(model, KIM_JEON_REFERENCE_FORCE_N, depth_mm, KIM_JEON_SPINDLE_RPM)
    h = 1e-3 * feed
    up = model.force_N(feed + h, depth_mm, KIM_JEON_SPINDLE_RPM)
    down = model.force_N(feed - h, depth_mm, KIM_JEON_SPINDLE_RPM)
    return mill.slope_A_per_N * (up - down) / (2.0 * h)


def case1_reference_current_A() -> float:
    """Spindle current that stands for 160 N on the Case-1 sensor [A] (3.206 + 0.922)."""
    mill = ForceCurrentMill(KimJeonForceModel())
    return mill.idle_current_A + mill.slope_A_per_N * KIM_JEON_REFERENCE_FORCE_N


def case1_controller(name: str, limits: FeedLimits = KIM_JEON_FEED_LIMITS) -> FeedController:
    """A fresh controller for Case 1: ``"pi"``, ``"fuzzy"`` or ``"corrective"``."""
    if name == "pi":
        gains = tai_pi_gains_for(case1_current_per_feed_A_per_mm_min(), PI_SAMPLE_PERIOD_S)
        return TaiPIController(limits, gains)
    if name == "fuzzy":
        return KimJeonFuzzyController(limits)
    if name == "corrective":
        return BorangiuCorrectiveController(limits)
    raise InputError("controller", name, f"must be one of {', '.join(CONTROLLERS)}")


def run_case1(name: str, seed: int = 0, controller: FeedController | None = None) -> MillRun:
    """Kim & Jeon Case 1 under one controller.

    Parameters
    ----------
    name : str
        ``"pi"`` (spindle current, 20 ms), ``"fuzzy"`` or ``"corrective"`` (force from the
        current, one revolution).
    seed : int
        Seed of the sensor noise; the same seed gives the same run.
    controller : FeedController, optional
        A controller to use instead of the default one of that name (same signal and rate).

    Returns
    -------
    MillRun
        The run, with per-segment metrics on the true force.
    """
    if name not in CONTROLLERS:
        raise InputError("controller", name, f"must be one of {', '.join(CONTROLLERS)}")
    chosen = controller or case1_controller(name)
    rng = np.random.default_rng(seed)
    if name == "pi":
        setup = case1_setup(sample_period_s=PI_SAMPLE_PERIOD_S)
        signal, reference = "spindle_current_A", case1_reference_current_A()
    else:
        setup = case1_setup()
        signal, reference = "force_N", KIM_JEON_REFERENCE_FORCE_N
    return simulate(
        setup,
        kim_jeon_case1_workpiece(),
        chosen,
        reference=reference,
        signal=signal,
        initial_feed_rate_mm_min=KIM_JEON_INITIAL_FEED_MM_MIN,
        rng=rng,
    )
