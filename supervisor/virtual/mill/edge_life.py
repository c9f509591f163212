r"""One edge's life under constant-load end milling, to the tool change (Tai et al. §III.C).

Tai et al. hold the spindle current at 0.24 A with the PI of Eq. 16; as the flank wear grows
the current rises (Eq. 14) and the controller lowers the feed (Eq. 15), until the feed
reaches its lower limit, the signal to change the tool. Their Table 1 lists the wear then:
175-214 µm, 197.26 µm on average, inside the 180-220 µm interval for four of five edges.

Here Tai et al.'s end milling is simulated pass after pass (150 mm passes at 0.2 × 1.4 mm,
10000 rpm) on the plane :data:`~supervisor.virtual.mill.tai_end_milling.TAI_END_MILLING`, with:

- wear growing with the removed volume (:class:`~supervisor.virtual.mill.process.WearLaw`, the rate
  from Tai et al.'s 2250 mm edge life);
- each edge a little different ("slightly different properties of the tools", §III.B): its
  wear rate scaled by ``exp(N(0, s_r²))`` and its ``k1`` by ``1 + N(0, s_k²)``, drawn first
  from the generator;
- the current read every 20 ms with noise 0.003 A (§III.B: the current's max-min spread
  7.6 % of 0.24 A, about six standard deviations of 0.003 A);
- the feed-override to current dynamics of Eq. 18 as a first-order lag of 0.254 s (its
  dominant poles, ``|z| = 0.924`` at 50 Hz: ``τ = −0.02/ln 0.924``).

The feed reaches its lower limit when ``B f + k1 V_B = I_ref − A``, so the wear then is set
by the limit (Eq. 15 at 205.1 µm) and by the edge's own ``k1``, not by its wear rate, which
only sets how long the edge lasts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from models import fields
from models.errors import InputError
from models.sensors import TaiCurrentFeedCalibration
from supervisor.virtual.mill.controllers.pi import TAI_PI_GAINS, TaiPIController, TaiPIGains
from supervisor.virtual.mill.feed_limits import FeedLimits
from supervisor.virtual.mill.process import (
    CurrentSensor,
    StepWorkpiece,
    TaiMill,
    WearLaw,
)
from supervisor.virtual.mill.run import MillRun, MillSetup, simulate
from supervisor.virtual.mill.tai_end_milling import (
    TAI_AXIAL_DEPTH_MM,
    TAI_END_MILLING,
    TAI_FEED_LIMITS,
    TAI_PASS_LENGTH_MM,
    TAI_RADIAL_DEPTH_MM,
    TAI_REFERENCE_CURRENT_A,
    TAI_SAMPLE_PERIOD_S,
    TAI_SPINDLE_RPM,
    TAI_TOOL_CHANGE_INTERVAL_MM,
    TAI_WEAR_RATE_MM_PER_MM3,
)


@dataclass(frozen=True)
class EdgeLifeConfig:
    """Tai et al.'s constant-load end milling, with the choices of the module docstring.

    Parameters
    ----------
    calibration : TaiCurrentFeedCalibration
        The nominal plane ``A, B, k1``.
    reference_current_A : float
        Reference current [A] (0.24 A).
    limits : FeedLimits
        Feed limits [mm/min] (1000 and 632.2 mm/min).
    tool_change_interval_mm : tuple[float, float]
        Flank wear interval for a tool change [mm] (180-220 µm).
    wear_rate_mm_per_mm3 : float
        Nominal flank wear per removed volume [mm/mm³].
    wear_rate_spread : float
        ``s_r``, log-normal spread of an edge's wear rate [-].
    wear_coefficient_spread : float
        ``s_k``, relative spread of an edge's ``k1`` [-].
    noise_sd_A : float
        Current noise per sample [A].
    feed_drive_time_constant_s : float
        Lag of the feed override [s].
    gains : TaiPIGains
        PI gains (the paper's).
    pass_length_mm : float
        Length of one pass [mm].
    max_passes : int
        Passes simulated at most.
    """

    calibration: TaiCurrentFeedCalibration = TAI_END_MILLING
    reference_current_A: float = TAI_REFERENCE_CURRENT_A
    limits: FeedLimits = TAI_FEED_LIMITS
    tool_change_interval_mm: tuple[float, float] = TAI_TOOL_CHANGE_INTERVAL_MM
    wear_rate_mm_per_mm3: float = TAI_WEAR_RATE_MM_PER_MM3
    wear_rate_spread: float = 0.15
    wear_coefficient_spread: float = 0.02
    noise_sd_A: float = 0.003
    feed_drive_time_constant_s: float = 0.254
    gains: TaiPIGains = TAI_PI_GAINS
    pass_length_mm: float = TAI_PASS_LENGTH_MM
    max_passes: int = 40

    def __post_init__(self) -> None:
        fields.check_fields(
            self,
            positives=("reference_current_A", "wear_rate_mm_per_mm3", "pass_length_mm"),
            non_negatives=(
                "wear_rate_spread",
                "wear_coefficient_spread",
                "noise_sd_A",
                "feed_drive_time_constant_s",
            ),
        )
        low, high = self.tool_change_interval_mm
        fields.at_least(low, "tool_change_interval_mm[0]")
        if not high > low:
            raise InputError(
                "tool_change_interval_mm", self.tool_change_interval_mm, "upper end must be above"
            )
        if isinstance(self.max_passes, bool) or not isinstance(self.max_passes, int):
            raise InputError("max_passes", self.max_passes, "must be a whole number")
        fields.positive(self.max_passes, "max_passes")


@dataclass(frozen=True)
class PassSummary:
    """One pass of the edge.

    Parameters
    ----------
    index : int
        Pass number, from 1.
    end_s : float
        Time at its last sample [s].
    feed_mean_mm_min : float
        Mean feed command over the pass [mm/min].
    current_mean_A : float
        Mean true spindle current over the pass [A].
    flank_wear_end_mm : float
        Flank wear at its end [mm].
    """

    index: int
    end_s: float
    feed_mean_mm_min: float
    current_mean_A: float
    flank_wear_end_mm: float


@dataclass(frozen=True, eq=False)
class EdgeLifeResult:
    """An edge from new to its tool change (compared by identity, like its run).

    Parameters
    ----------
    run : MillRun
        The whole time series.
    passes : tuple of PassSummary
        Per pass (the last one possibly cut short by the tool change).
    changed : bool
        Whether the feed reached its lower limit within ``max_passes``.
    flank_wear_at_change_mm : float
        Flank wear when the feed reached the lower limit (or at the end) [mm].
    cut_length_mm : float
        Path cut by the edge [mm].
    wear_rate_mm_per_mm3 : float
        This edge's wear rate [mm/mm³].
    wear_coefficient_A_per_mm : float
        This edge's ``k1`` [A/mm].
    tool_change_interval_mm : tuple[float, float]
        The interval the wear should end in [mm].
    """

    run: MillRun
    passes: tuple[PassSummary, ...]
    changed: bool
    flank_wear_at_change_mm: float
    cut_length_mm: float
    wear_rate_mm_per_mm3: float
    wear_coefficient_A_per_mm: float
    tool_change_interval_mm: tuple[float, float]

    @property
    def inside_interval(self) -> bool:
        """Whether the tool change came with the wear inside the interval."""
        low, high = self.tool_change_interval_mm
        return self.changed and low <= self.flank_wear_at_change_mm <= high


def tai_wear_at_feed_mm(
    calibration: TaiCurrentFeedCalibration, current_A: float, feed_rate_mm_min: float
) -> float:
    r"""Flank wear at which a feed rate draws a current (Tai et al. Eq. 14 solved for VB).

    .. math:: V_B = \frac{I - A - B f}{k_1}

    Parameters
    ----------
    calibration : TaiCurrentFeedCalibration
        ``A, B, k1`` (``k1 > 0``).
    current_A : float
        Spindle current [A].
    feed_rate_mm_min : float
        Feed rate [mm/min].

    Returns
    -------
    float
        ``V_B`` [mm] (negative if the sharp tool already draws more).
    """
    k1 = fields.positive(
        calibration.wear_coefficient_A_per_mm, "calibration.wear_coefficient_A_per_mm"
    )
    cutting = calibration.idle_current_A + calibration.slope_A_per_mm_min * feed_rate_mm_min
    return (current_A - cutting) / k1


def simulate_edge_life(config: EdgeLifeConfig, rng: np.random.Generator) -> EdgeLifeResult:
    """One edge under constant-load PI control, pass after pass, to its tool change.

    Parameters
    ----------
    config : EdgeLifeConfig
        Process, controller and spreads.
    rng : numpy.random.Generator
        Draws the edge (wear rate, ``k1``), then the sensor noise.

    Returns
    -------
    EdgeLifeResult
        The edge's series, pass summaries and the wear when the feed reached its limit.
    """
    nominal = config.calibration
    rate = config.wear_rate_mm_per_mm3 * math.exp(config.wear_rate_spread * rng.standard_normal())
    k1 = nominal.wear_coefficient_A_per_mm * (
        1.0 + config.wear_coefficient_spread * float(rng.standard_normal())
    )
    edge = replace(nominal, wear_coefficient_A_per_mm=max(k1, 0.0))
    setup = MillSetup(
        process=TaiMill(edge, nominal_depth_mm=TAI_AXIAL_DEPTH_MM),
        spindle_rpm=TAI_SPINDLE_RPM,
        radial_depth_mm=TAI_RADIAL_DEPTH_MM,
        sensor=CurrentSensor(noise_sd_A=config.noise_sd_A),
        feed_drive_time_constant_s=config.feed_drive_time_constant_s,
        wear=WearLaw(rate),
        sample_period_s=TAI_SAMPLE_PERIOD_S,
    )
    passes = ((config.pass_length_mm, TAI_AXIAL_DEPTH_MM),) * config.max_passes
    run = simulate(
        setup,
        StepWorkpiece(passes),
        TaiPIController(config.limits, config.gains),
        reference=config.reference_current_A,
        signal="spindle_current_A",
        initial_feed_rate_mm_min=config.limits.upper_feed_rate_mm_min,
        rng=rng,
        stop_at_lower_limit=True,
    )
    return EdgeLifeResult(
        run=run,
        passes=_passes(run, config.pass_length_mm),
        changed=run.stopped_at_lower_limit,
        flank_wear_at_change_mm=float(run.flank_wear_mm[-1]),
        cut_length_mm=float(run.position_mm[-1]),
        wear_rate_mm_per_mm3=rate,
        wear_coefficient_A_per_mm=edge.wear_coefficient_A_per_mm,
        tool_change_interval_mm=config.tool_change_interval_mm,
    )


def _passes(run: MillRun, pass_length_mm: float) -> tuple[PassSummary, ...]:
    """Summaries of the passes (by path position)."""
    index = np.floor(run.position_mm / pass_length_mm).astype(int)
    summaries = []
    for k in np.unique(index):
        mask = index == k
        summaries.append(
            PassSummary(
                index=int(k) + 1,
                end_s=float(run.time_s[mask][-1]),
                feed_mean_mm_min=float(run.feed_command_mm_min[mask].mean()),
                current_mean_A=float(run.current_A[mask].mean()),
                flank_wear_end_mm=float(run.flank_wear_mm[mask][-1]),
            )
        )
    return tuple(summaries)
