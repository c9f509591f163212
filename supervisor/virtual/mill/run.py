r"""The time-stepping loop of the virtual mill and its frozen results.

One sample every ``Δt`` (the controller's period: one spindle revolution ``60/n`` s for Kim &
Jeon and Borangiu et al., 20 ms for Tai et al.):

1. the feed drive follows the last command with a first-order lag,
   ``f ← c + (f − c)·exp(−Δt/τ)``, exact for a command held over the sample;
2. the tool advances ``Δx = Δt·(f_old + f)/120`` mm, removes ``d·a_e·Δx`` mm³ and wears
   by :class:`~supervisor.virtual.mill.process.WearLaw`;
3. the process gives the true force and spindle current at the new depth;
4. the sensor lags the current (:class:`~supervisor.virtual.mill.process.CurrentSensor`) and adds
   noise ``N(0, σ²)`` drawn from the generator passed in (the only randomness);
5. the controller reads the current, or the force converted from it with the process's
   calibration (:func:`models.sensors.linear_current_force_N`, Kim & Jeon §7), and issues
   the next feed command.

Steady state of a segment: its last third in time (``steady_fraction``). Its metrics are the
mean and largest ``|F − F_ref|/F_ref`` of the true force there (or of the true current when
the process models no force), and the largest and smallest feed command over the segment.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from models import fields
from models.errors import InputError
from models.sensors import linear_current_force_N
from supervisor.virtual.mill.controllers.base import FeedController
from supervisor.virtual.mill.feed_limits import FeedLimits
from supervisor.virtual.mill.process import CurrentSensor, CutProcess, StepWorkpiece, WearLaw

#: Signals a controller can be closed on.
SIGNALS = ("force_N", "spindle_current_A")

Series = npt.NDArray[np.float64]


@dataclass(frozen=True)
class MillSetup:
    """The virtual mill: process, spindle, sensor, feed drive, wear, sampling.

    Parameters
    ----------
    process : CutProcess
        True force and spindle current.
    spindle_rpm : float
        Spindle speed at the start [rpm] (a controller may change it).
    radial_depth_mm : float
        Radial depth of cut ``a_e`` [mm] (for the removed volume).
    sensor : CurrentSensor
        Lag and noise of the current reading.
    feed_drive_time_constant_s : float
        ``τ`` of the feed drive [s], ``>= 0``.
    wear : WearLaw
        Flank-wear growth.
    sample_period_s : float or None
        Controller period [s]; None for one spindle revolution, ``60/n``.
    """

    process: CutProcess
    spindle_rpm: float
    radial_depth_mm: float
    sensor: CurrentSensor = field(default_factory=CurrentSensor)
    feed_drive_time_constant_s: float = 0.0
    wear: WearLaw = field(default_factory=WearLaw)
    sample_period_s: float | None = None

    def __post_init__(self) -> None:
        fields.check_fields(
            self,
            positives=("spindle_rpm", "radial_depth_mm"),
            non_negatives=("feed_drive_time_constant_s",),
        )
        if self.sample_period_s is not None:
            object.__setattr__(
                self, "sample_period_s", fields.positive(self.sample_period_s, "sample_period_s")
            )


@dataclass(frozen=True)
class SegmentMetrics:
    """Steady-state behaviour in one depth segment.

    Parameters
    ----------
    depth_mm : float
        Depth of cut of the segment [mm].
    start_s, end_s : float
        First and last sample in the segment [s].
    steady_from_s : float
        Start of the steady-state window [s].
    deviation_mean_rel, deviation_max_rel : float
        Mean and largest ``|y − y_ref|/y_ref`` of the true force (or current) in the window.
    feed_mean_steady_mm_min : float
        Mean feed command in the window [mm/min].
    feed_max_mm_min, feed_min_mm_min : float
        Largest and smallest feed command over the segment [mm/min].
    """

    depth_mm: float
    start_s: float
    end_s: float
    steady_from_s: float
    deviation_mean_rel: float
    deviation_max_rel: float
    feed_mean_steady_mm_min: float
    feed_max_mm_min: float
    feed_min_mm_min: float


@dataclass(frozen=True, eq=False)
class MillRun:
    """Time series of one simulated run (read-only arrays, one entry per sample).

    Compared by identity (its arrays have no single truth value); compare series with
    ``numpy.array_equal``.

    Parameters
    ----------
    signal : str
        The controlled signal, one of :data:`SIGNALS`.
    reference : float
        Its reference [N] or [A].
    reference_force_N : float
        The force the reference stands for [N] (NaN when the process models no force).
    limits : FeedLimits
        The controller's feed limits.
    time_s, position_mm, depth_mm, force_N, current_A, measured, feed_command_mm_min, \
feed_rate_mm_min, spindle_rpm, flank_wear_mm : numpy.ndarray
        Time [s], path position [mm], depth of cut [mm], true force [N], true spindle current
        [A], the controller's input [N or A], feed command [mm/min], actual feed rate
        [mm/min], spindle speed [rpm], flank wear [mm].
    segments : tuple of SegmentMetrics
        One per workpiece segment that was reached.
    stopped_at_lower_limit : bool
        Whether the run stopped because the feed command reached its lower limit.
    """

    signal: str
    reference: float
    reference_force_N: float
    limits: FeedLimits
    time_s: Series
    position_mm: Series
    depth_mm: Series
    force_N: Series
    current_A: Series
    measured: Series
    feed_command_mm_min: Series
    feed_rate_mm_min: Series
    spindle_rpm: Series
    flank_wear_mm: Series
    segments: tuple[SegmentMetrics, ...]
    stopped_at_lower_limit: bool


_SERIES = (
    "time_s",
    "position_mm",
    "depth_mm",
    "force_N",
    "current_A",
    "measured",
    "feed_command_mm_min",
    "feed_rate_mm_min",
    "spindle_rpm",
    "flank_wear_mm",
)


def simulate(
    setup: MillSetup,
    workpiece: StepWorkpiece,
    controller: FeedController,
    *,
    reference: float,
    signal: str,
    initial_feed_rate_mm_min: float,
    rng: np.random.Generator,
    initial_flank_wear_mm: float = 0.0,
    stop_at_lower_limit: bool = False,
    max_time_s: float | None = None,
    steady_fraction: float = 1.0 / 3.0,
) -> MillRun:
    """Run the workpiece's path under closed-loop feed control.

    Parameters
    ----------
    setup : MillSetup
        The virtual mill.
    workpiece : StepWorkpiece
        The depth profile; the run ends at its end.
    controller : FeedController
        Reset here to the initial feed and the setup's spindle speed.
    reference : float
        Reference of ``signal`` [N] or [A], ``> 0``.
    signal : str
        ``"force_N"`` (converted from the current) or ``"spindle_current_A"``.
    initial_feed_rate_mm_min : float
        Feed rate at the start [mm/min] (the program's F).
    rng : numpy.random.Generator
        Source of the sensor noise.
    initial_flank_wear_mm : float
        Flank wear at the start [mm].
    stop_at_lower_limit : bool
        End the run when the feed command reaches the lower limit (tool change, Tai et al.).
    max_time_s : float, optional
        Simulated-time guard [s]; default 1.5 times the path at the lower limit, plus 10 s.
    steady_fraction : float
        Last fraction of each segment's time taken as its steady state [-], in (0, 1].

    Returns
    -------
    MillRun
        The series and the per-segment metrics.
    """
    wear_mm, feed_mm_min = initial_flank_wear_mm, initial_feed_rate_mm_min
    inputs = (signal, reference, steady_fraction, max_time_s, wear_mm, feed_mm_min)
    start = _start(setup, workpiece, controller, *inputs)
    rows, stopped = _time_steps(setup, workpiece, controller, start, rng, stop_at_lower_limit)
    series = _read_only_series(rows)
    ref = start.reference
    ref_force = _reference_force(ref, signal, start.calibration)
    segments = _segment_metrics(workpiece, series, ref, ref_force, steady_fraction)
    limits = start.limits
    return MillRun(
        signal, ref, ref_force, limits, segments=segments, **series, stopped_at_lower_limit=stopped
    )


@dataclass(frozen=True)
class _Start:
    """A run's checked inputs: the signal, its reference, the horizon and the initial state."""

    signal: str
    reference: float
    calibration: Any
    limits: FeedLimits
    horizon_s: float
    flank_wear_mm: float
    feed_rate_mm_min: float


def _start(
    setup: MillSetup,
    workpiece: StepWorkpiece,
    controller: FeedController,
    signal: str,
    reference: float,
    steady_fraction: float,
    max_time_s: float | None,
    initial_flank_wear_mm: float,
    initial_feed_rate_mm_min: float,
) -> _Start:
    """Check the inputs of :func:`simulate`; the horizon's default from the lower feed limit."""
    if signal not in SIGNALS:
        raise InputError("signal", signal, f"must be one of {', '.join(SIGNALS)}")
    ref = fields.positive(reference, "reference")
    if not 0.0 < steady_fraction <= 1.0:
        raise InputError("steady_fraction", steady_fraction, "must lie in (0, 1]")
    calibration = setup.process.force_calibration()
    if signal == "force_N" and calibration is None:
        raise InputError("signal", signal, "the process has no current → force calibration")
    limits = controller.limits
    if max_time_s is None:
        max_time_s = 1.5 * workpiece.length_mm / limits.lower_feed_rate_mm_min * 60.0 + 10.0
    horizon = fields.positive(max_time_s, "max_time_s")
    wear = fields.at_least(initial_flank_wear_mm, "initial_flank_wear_mm")
    feed = fields.positive(initial_feed_rate_mm_min, "initial_feed_rate_mm_min")
    return _Start(signal, ref, calibration, limits, horizon, wear, feed)


def _time_steps(
    setup: MillSetup,
    workpiece: StepWorkpiece,
    controller: FeedController,
    start: _Start,
    rng: np.random.Generator,
    stop_at_lower_limit: bool,
) -> tuple[list[tuple[float, ...]], bool]:
    """Steps 1-5 of the module's loop, one row of :data:`_SERIES` per sample.

    Returns the rows and whether the run stopped at the lower feed limit.
    """
    signal, ref, calibration = start.signal, start.reference, start.calibration
    limits, wear, feed = start.limits, start.flank_wear_mm, start.feed_rate_mm_min
    controller.reset(feed, setup.spindle_rpm)
    command = limits.clamp(feed)
    process, sensor = setup.process, setup.sensor
    depth = workpiece.depth_mm(0.0)
    filtered = process.current_A(feed, depth, controller.spindle_rpm, wear)
    t = x = 0.0
    rows: list[tuple[float, ...]] = []
    while t < start.horizon_s and x < workpiece.length_mm:
        n = controller.spindle_rpm
        dt = setup.sample_period_s or 60.0 / n
        previous = feed
        tau = setup.feed_drive_time_constant_s
        feed = command + (feed - command) * math.exp(-dt / tau) if tau > 0 else command
        dx = dt * (previous + feed) / 120.0
        wear += setup.wear.rate_mm_per_mm3 * depth * setup.radial_depth_mm * dx
        x += dx
        t += dt
        depth = workpiece.depth_mm(x)
        force = process.force_N(feed, depth, n, wear)
        current = process.current_A(feed, depth, n, wear)
        filtered += sensor.smoothing(dt) * (current - filtered)
        reading = filtered
        if sensor.noise_sd_A > 0.0:
            reading += sensor.noise_sd_A * float(rng.standard_normal())
        measured = reading
        if signal == "force_N" and calibration is not None:
            measured = linear_current_force_N(calibration, max(reading, 0.0)).value
        command = controller.step(measured, ref, dt)
        rows.append((t, x, depth, force, current, measured, command, feed, n, wear))
        if stop_at_lower_limit and limits.at_lower(command):
            return rows, True
    return rows, False


def _read_only_series(rows: list[tuple[float, ...]]) -> dict[str, Any]:
    """The rows of :func:`_time_steps` as one read-only array per name of :data:`_SERIES`."""
    data = np.array(rows, dtype=float).reshape(-1, len(_SERIES))
    series: dict[str, Any] = {}
    for i, name in enumerate(_SERIES):
        column = np.ascontiguousarray(data[:, i])
        column.flags.writeable = False
        series[name] = column
    return series


def _reference_force(reference: float, signal: str, calibration: Any) -> float:
    """The force [N] a reference stands for; NaN without a calibration."""
    if signal == "force_N":
        return reference
    if calibration is None:
        return math.nan
    return float(linear_current_force_N(calibration, reference).value)


def _segment_metrics(
    workpiece: StepWorkpiece,
    series: dict[str, Any],
    reference: float,
    reference_force_N: float,
    steady_fraction: float,
) -> tuple[SegmentMetrics, ...]:
    """Steady-state metrics of each segment reached (see the module)."""
    time, position = series["time_s"], series["position_mm"]
    if math.isnan(reference_force_N):
        values, target = series["current_A"], reference
    else:
        values, target = series["force_N"], reference_force_N
    metrics = []
    start = 0.0
    for (_, depth), end in zip(workpiece.segments, workpiece.boundaries_mm, strict=True):
        inside = (position >= start) & (position < end)
        start = end
        if not inside.any():
            break
        t0, t1 = float(time[inside][0]), float(time[inside][-1])
        steady_from = t1 - steady_fraction * (t1 - t0)
        window = inside & (time >= steady_from)
        deviation = np.abs(values[window] - target) / target
        feeds = series["feed_command_mm_min"]
        metrics.append(
            SegmentMetrics(
                depth_mm=depth,
                start_s=t0,
                end_s=t1,
                steady_from_s=steady_from,
                deviation_mean_rel=float(deviation.mean()),
                deviation_max_rel=float(deviation.max()),
                feed_mean_steady_mm_min=float(feeds[window].mean()),
                feed_max_mm_min=float(feeds[inside].max()),
                feed_min_mm_min=float(feeds[inside].min()),
            )
        )
    return tuple(metrics)
