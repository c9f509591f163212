r"""Kim & Jeon (Precision Engineering 2011), §6.2.3 and §7: current → force at several feed rates.

The spindle current-force relation "changes as the feed rate changes": linear calibrations at
several feed rates (:mod:`models.sensors.kim_jeon`) interpolated in between, with Kim & Jeon's
own at 4500 rpm (read from ``models/data/kim_jeon_current_force.toml``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from models import fields
from models.data import read_toml
from models.errors import InputError, ModelDomainError
from models.sensors.converted import Converted
from models.sensors.kim_jeon import (
    LinearCurrentCalibration,
    _linear_force,
    calibration_from_current_relation,
)


@dataclass(frozen=True)
class FeedDependentCurrentCalibration:
    """Linear current → force calibrations at several feed rates, interpolated in between.

    Kim & Jeon (§6.2.3, §7) find that the spindle current-force relation "changes as the feed
    rate changes" and must be "predetermined at different feed rates"; the paper gives it at
    three feed rates, not as a law in the feed, and the slopes are not monotonic in it. So
    offset and slope are interpolated linearly between the calibrated feed rates, and a feed
    rate outside them is refused.

    Parameters
    ----------
    points : tuple of LinearCurrentCalibration
        At least 2, each with ``feed_rate_mm_min``, in increasing feed rate.
    spindle_speed_rpm : float or None
        Spindle speed of the calibration [rpm] (see :class:`LinearCurrentCalibration`).
    speed_tolerance_rel : float
        Relative tolerance on the spindle speed [-].
    source, reference, date, notes : str
        Provenance.
    """

    kind: ClassVar[str] = "linear_current_by_feed"

    points: tuple[LinearCurrentCalibration, ...]
    spindle_speed_rpm: float | None = None
    speed_tolerance_rel: float = 0.05
    source: str = ""
    reference: str = ""
    date: str = ""
    notes: str = ""

    def __post_init__(self) -> None:
        points = tuple(self.points)
        if len(points) < 2:
            raise InputError("points", self.points, "needs at least 2 calibrated feed rates")
        feeds = []
        for i, point in enumerate(points):
            if not isinstance(point, LinearCurrentCalibration):
                raise InputError(f"points[{i}]", point, "must be a linear current calibration")
            if point.feed_rate_mm_min is None:
                raise InputError(f"points[{i}].feed_rate_mm_min", None, "required field missing")
            feeds.append(point.feed_rate_mm_min)
        if any(b <= a for a, b in zip(feeds, feeds[1:], strict=False)):
            raise InputError("points", feeds, "feed rates must be increasing")
        fields.check_field(self, "spindle_speed_rpm", positive=True, optional=True)
        fields.check_field(self, "speed_tolerance_rel", minimum=0.0)
        object.__setattr__(self, "points", points)

    @property
    def feed_rates_mm_min(self) -> tuple[float, ...]:
        """The calibrated feed rates [mm/min]."""
        return tuple(float(p.feed_rate_mm_min or 0.0) for p in self.points)


_FILE = "kim_jeon_current_force.toml"


def _kim_jeon_calibration() -> FeedDependentCurrentCalibration:
    """Kim & Jeon's relations at 4500 rpm, read from ``models/data/kim_jeon_current_force.toml``."""
    data = read_toml(_FILE)
    relations = data["relations"]
    if isinstance(relations, str | bytes) or not isinstance(relations, list):
        raise InputError(f"{_FILE}:relations", relations, "must be a list of tables")
    points = []
    for i, entry in enumerate(relations):
        where = f"{_FILE}:relations[{i}]"
        table = fields.mapping(entry, where)
        points.append(
            calibration_from_current_relation(
                fields.number(table["slope_A_per_N"], f"{where}.slope_A_per_N"),
                fields.number(table["offset_A"], f"{where}.offset_A"),
                feed_rate_mm_min=fields.number(
                    table["feed_rate_mm_min"], f"{where}.feed_rate_mm_min"
                ),
            )
        )
    return FeedDependentCurrentCalibration(
        points=tuple(points),
        spindle_speed_rpm=fields.number(data["spindle_speed_rpm"], f"{_FILE}:spindle_speed_rpm"),
        source=fields.text(data, "source", _FILE),
        reference=fields.text(data, "reference", _FILE),
    )


#: Kim & Jeon's maximum force per revolution vs spindle RMS current on the ACE-V30 at
#: 4500 rpm, three feed rates (§6.2.3); the paper gives no uncertainties.
KIM_JEON_SPINDLE_FMAX_4500RPM = _kim_jeon_calibration()


def feed_dependent_force_N(
    calibration: FeedDependentCurrentCalibration,
    current_A: float,
    u_current_A: float,
    feed_rate_mm_min: float,
    *,
    u_feed_rate_mm_min: float = 0.0,
    include_residual: bool = True,
) -> Converted:
    r"""Cutting force from the spindle current at a feed rate (Kim & Jeon §6.2.3 and §7).

    .. math::

        F = (1-w) F_j(I) + w F_{j+1}(I), \quad w = \frac{f - f_j}{f_{j+1} - f_j}, \quad
        F_j(I) = a_j + b_j I

    .. math::

        u_F^2 = \big(b(f)\,u_I\big)^2 + (1-w)^2 u_{F_j,\text{cal}}^2
            + w^2 u_{F_{j+1},\text{cal}}^2 + \Big(\frac{F_{j+1} - F_j}{f_{j+1} - f_j} u_f\Big)^2
            + (1-w) s_j^2 + w s_{j+1}^2

    with the calibrations at different feed rates independent. The interpolation's own model
    error between calibrated feeds is not included.

    Parameters
    ----------
    calibration : FeedDependentCurrentCalibration
        Lines at two or more feed rates.
    current_A, u_current_A : float
        RMS spindle current and its standard uncertainty [A].
    feed_rate_mm_min : float
        Feed rate [mm/min], within the calibrated feed rates.
    u_feed_rate_mm_min : float
        Its standard uncertainty [mm/min].
    include_residual : bool
        Add the residual scatter ``s`` (see :func:`linear_current_force_N`).

    Returns
    -------
    Converted
        Force [N] and its standard uncertainty [N].

    References
    ----------
    .. [1] Kim & Jeon, §6.2.3 and §7 ("the current-force relation at different feed rates
       needs to be predetermined").
    """
    return _feed_dependent_force(
        calibration,
        fields.number(current_A, "current_A", minimum=0.0),
        fields.uncertainty(u_current_A, "u_current_A"),
        fields.number(feed_rate_mm_min, "feed_rate_mm_min", positive=True),
        fields.uncertainty(u_feed_rate_mm_min, "u_feed_rate_mm_min"),
        include_residual,
        "feed_rate_mm_min",
    )


def _feed_dependent_force(
    calibration: FeedDependentCurrentCalibration,
    current: float,
    u_current: float,
    feed: float,
    u_feed: float,
    include_residual: bool,
    feed_field: str,
) -> Converted:
    feeds = calibration.feed_rates_mm_min
    if not feeds[0] <= feed <= feeds[-1]:
        raise ModelDomainError(
            feed_field, feed, f"outside the calibrated feed rates ({feeds[0]:g} to {feeds[-1]:g})"
        )
    j = min(int(np.searchsorted(feeds, feed, side="right")) - 1, len(feeds) - 2)
    w = (feed - feeds[j]) / (feeds[j + 1] - feeds[j])
    lo, hi = calibration.points[j], calibration.points[j + 1]
    f_lo, _, var_lo = _linear_force(lo, current, 0.0, False)
    f_hi, _, var_hi = _linear_force(hi, current, 0.0, False)
    force = (1.0 - w) * f_lo + w * f_hi
    slope = (1.0 - w) * lo.slope_N_per_A + w * hi.slope_N_per_A
    dF_dfeed = (f_hi - f_lo) / (feeds[j + 1] - feeds[j])
    var = (
        (slope * u_current) ** 2
        + (1.0 - w) ** 2 * var_lo
        + w**2 * var_hi
        + (dF_dfeed * u_feed) ** 2
    )
    if include_residual:
        var += (1.0 - w) * lo.residual_sd_N**2 + w * hi.residual_sd_N**2
    return Converted(force, math.sqrt(var))
