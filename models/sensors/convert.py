"""The one entry point for part reports: a raw spindle reading → cutting force, :func:`to_force`.

Dispatches on the calibration's kind: spindle load by Ivester & Heigel Eqs. 1-4, spindle
current by Kim & Jeon §6.2.3 (one line, or lines per feed rate). Uncertainties in and out are
expanded ones at a coverage factor ``k`` (GUM, JCGM 100:2008, §6.2).

The ``context`` each calibration kind needs, each entry in the unit its name carries
(uncertainties ``u_*`` expanded, at the coverage factor of the call):

- ``ivester_spindle_load``: ``spindle_speed_rpm``, ``workpiece_diameter_mm`` (required);
  ``u_workpiece_diameter_mm``; ``idle_load_V`` and ``u_idle_load_V`` (required unless the
  calibration has an idle-load table; a measured idle load takes precedence over the table).
- ``linear_current``: ``spindle_speed_rpm`` if the calibration names its speed.
- ``linear_current_by_feed``: ``feed_rate_mm_min`` (required), ``u_feed_rate_mm_min``;
  ``spindle_speed_rpm`` as above.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from typing import Literal

from models import fields
from models.bounds import LARGEST
from models.errors import InputError, ModelDomainError
from models.sensors.converted import Converted
from models.sensors.ivester import IvesterSpindleLoadCalibration, _ivester_force, _ivester_idle
from models.sensors.kim_jeon import LinearCurrentCalibration, _linear_force
from models.sensors.kim_jeon_feed import FeedDependentCurrentCalibration, _feed_dependent_force
from models.sensors.tai import TaiCurrentFeedCalibration

RawQuantity = Literal["spindle_load_V", "spindle_current_A"]
#: The raw sensor quantities :func:`to_force` converts.
RAW_QUANTITIES: tuple[RawQuantity, ...] = ("spindle_load_V", "spindle_current_A")


Calibration = (
    IvesterSpindleLoadCalibration
    | LinearCurrentCalibration
    | FeedDependentCurrentCalibration
    | TaiCurrentFeedCalibration
)

#: The raw quantity each force calibration kind converts.
_CONVERTS: dict[str, RawQuantity] = {
    IvesterSpindleLoadCalibration.kind: "spindle_load_V",
    LinearCurrentCalibration.kind: "spindle_current_A",
    FeedDependentCurrentCalibration.kind: "spindle_current_A",
}


def converts(calibration: Calibration) -> RawQuantity | None:
    """The raw quantity a calibration converts to force (None: it does not give a force)."""
    return _CONVERTS.get(calibration.kind)


def _context_required(context: Mapping[str, object], key: str) -> float:
    """A positive number the conversion needs from ``context``."""
    if key not in context:
        raise InputError(f"context.{key}", None, "required for this conversion")
    return fields.number(context[key], f"context.{key}", positive=True)


def _context_optional(
    context: Mapping[str, object], key: str, default: float | None
) -> float | None:
    """A number ``>= 0`` the conversion may take from ``context``."""
    if key not in context:
        return default
    return fields.number(context[key], f"context.{key}", minimum=0.0)


def _check_speed(
    cal_speed_rpm: float | None, tolerance: float, context: Mapping[str, object]
) -> None:
    if cal_speed_rpm is None:
        return
    speed = _context_required(context, "spindle_speed_rpm")
    if abs(speed - cal_speed_rpm) > tolerance * cal_speed_rpm:
        raise ModelDomainError(
            "context.spindle_speed_rpm",
            speed,
            f"the calibration holds at {cal_speed_rpm:g} rpm (±{100 * tolerance:g} %)",
        )


def _check_kind(calibration: Calibration, raw_quantity: str) -> None:
    """Refuse a calibration that gives no force, or a reading it does not convert."""
    kind = getattr(calibration, "kind", None)
    if isinstance(calibration, TaiCurrentFeedCalibration):
        raise InputError(
            "calibration.kind",
            kind,
            "converts spindle current to feed rate, not to force (see tai_feed_rate_mm_min)",
        )
    if kind not in _CONVERTS:
        raise InputError(
            "calibration.kind", kind, f"unknown; expected one of: {', '.join(_CONVERTS)}"
        )
    if raw_quantity not in RAW_QUANTITIES:
        raise InputError(
            "raw_quantity", raw_quantity, f"unknown; expected one of: {', '.join(RAW_QUANTITIES)}"
        )
    if raw_quantity != _CONVERTS[kind]:
        raise InputError(
            "raw_quantity", raw_quantity, f"a {kind} calibration converts {_CONVERTS[kind]}"
        )


def _checked_reading(
    value: float, uncertainty: float, coverage_k: float, name: str
) -> tuple[float, float, float]:
    """The coverage factor, the reading and its standard uncertainty, each checked."""
    k = fields.number(coverage_k, "coverage_k", positive=True)
    reading = fields.number(value, f"{name}.value", minimum=0.0)
    return k, reading, fields.uncertainty(uncertainty, f"{name}.uncertainty") / k


def _ivester_from_context(
    calibration: IvesterSpindleLoadCalibration,
    reading: float,
    u_reading: float,
    context: Mapping[str, object],
    k: float,
) -> tuple[Converted, str]:
    """Spindle load to force (Ivester & Heigel Eqs. 1-4); the idle load measured, else tabled.

    Returns the standard-uncertainty result and what a negative force means here.
    """
    speed = _context_required(context, "spindle_speed_rpm")
    diameter = _context_required(context, "workpiece_diameter_mm")
    u_diameter = _context_optional(context, "u_workpiece_diameter_mm", 0.0) or 0.0
    idle = _context_optional(context, "idle_load_V", None)
    if idle is not None:
        u_idle = (_context_optional(context, "u_idle_load_V", 0.0) or 0.0) / k
    elif calibration.idle_speeds_rpm:
        idle, u_idle = _ivester_idle(calibration, speed, "context.spindle_speed_rpm")
    else:
        raise InputError(
            "context.idle_load_V", None, "required: the calibration has no idle-load table"
        )
    result = _ivester_force(
        calibration, reading, u_reading, idle, u_idle, speed, diameter, u_diameter / k
    )
    return result, f"below the idle load {idle:.6g} V at this speed (no cutting)"


def _force(
    calibration: Calibration,
    reading: float,
    u_reading: float,
    context: Mapping[str, object],
    k: float,
    include_residual: bool,
) -> tuple[Converted, str]:
    """The force by the calibration's kind (standard uncertainty), and what a negative one means.

    Spindle load by Ivester & Heigel Eqs. 1-4; spindle current by Kim & Jeon §6.2.3.
    """
    context = fields.mapping(context, "context")
    if isinstance(calibration, IvesterSpindleLoadCalibration):
        return _ivester_from_context(calibration, reading, u_reading, context, k)
    if isinstance(calibration, LinearCurrentCalibration):
        _check_speed(calibration.spindle_speed_rpm, calibration.speed_tolerance_rel, context)
        force, var_current, var_cal = _linear_force(
            calibration, reading, u_reading, include_residual
        )
        below = "below the calibration's zero-force current"
        return Converted(force, math.sqrt(var_current + var_cal)), below
    if isinstance(calibration, FeedDependentCurrentCalibration):
        _check_speed(calibration.spindle_speed_rpm, calibration.speed_tolerance_rel, context)
        feed = _context_required(context, "feed_rate_mm_min")
        u_feed = _context_optional(context, "u_feed_rate_mm_min", 0.0) or 0.0
        result = _feed_dependent_force(
            calibration,
            reading,
            u_reading,
            feed,
            u_feed / k,
            include_residual,
            "context.feed_rate_mm_min",
        )
        return result, "below the calibration's zero-force current at this feed rate"
    raise InputError(  # pragma: no cover - every kind in _CONVERTS is handled above
        "calibration.kind", calibration.kind, "not a force calibration"
    )


def to_force(
    calibration: Calibration,
    raw_quantity: str,
    value: float,
    uncertainty: float,
    context: Mapping[str, object],
    *,
    coverage_k: float = 2.0,
    include_residual: bool = True,
    path: str | None = None,
) -> Converted:
    """Convert a raw spindle reading to a cutting force with its expanded uncertainty.

    Parameters
    ----------
    calibration : Calibration
        An ``ivester_spindle_load``, ``linear_current`` or ``linear_current_by_feed``
        calibration (a ``tai_current_feed`` one converts current to feed rate, not force).
    raw_quantity : str
        ``spindle_load_V`` or ``spindle_current_A``; must be what the calibration converts.
    value : float
        The reading [V] or [A], ``>= 0``.
    uncertainty : float
        Its expanded uncertainty (coverage ``coverage_k``) [V] or [A].
    context : Mapping[str, object]
        What the conversion needs, by calibration kind (listed in the module docstring);
        keys it does not use are ignored.
    coverage_k : float
        Coverage factor of the given and returned uncertainties (2: the ±2σ of part
        reports). Calibration uncertainties are standard ones and are scaled by it.
    include_residual : bool
        Current calibrations: add the residual scatter ``s`` (see :func:`linear_current_force_N`).
    path : str, optional
        Errors name the reading ``{path}.value``, ``{path}.uncertainty`` (default ``raw_quantity``).

    Returns
    -------
    Converted
        ``force_N`` and its expanded uncertainty [N] (coverage ``coverage_k``); unpacks as
        ``force_N, u_force_N``.

    Raises
    ------
    InputError
        Naming the field: an unknown calibration kind or raw quantity, a bad value, a missing
        or bad context entry (``{path}.spindle_speed_rpm``, no path ``context.`` ...), or a
        reading outside the calibration (a negative force: a load below the idle load or a
        current below the zero-force current; a speed or feed rate outside its range).

    References
    ----------
    .. [1] Ivester & Heigel, Eqs. 1-4 (spindle load); Kim & Jeon §6.2.3 (spindle current).
    """
    name = path or raw_quantity
    _check_kind(calibration, raw_quantity)
    k, reading, u_reading = _checked_reading(value, uncertainty, coverage_k, name)
    with _context_at(path):
        result, below = _force(calibration, reading, u_reading, context, k, include_residual)
    return _bounded(result, k, value, uncertainty, name, below)


@contextmanager
def _context_at(path: str | None) -> Iterator[None]:
    """A context entry's error named as the reading's field that gives it (``{path}.KEY``).

    A part report's reading carries its conversion's context as its own fields
    (``spindle_speed_rpm``, ``idle_load_V``); without a path, as ``context.KEY``.
    """
    try:
        yield
    except InputError as err:
        if not (path and err.field.startswith("context.")):
            raise
        key = err.field.removeprefix("context.")
        raise type(err)(f"{path}.{key}", err.value, err.reason) from None


def _bounded(
    result: Converted, k: float, value: float, uncertainty: float, name: str, below: str
) -> Converted:
    """The force and its uncertainty at coverage ``k``: a force >= 0, each at most ``LARGEST``.

    :data:`models.bounds.LARGEST` bounds every number, read or converted (NaN refused too);
    ``below`` says why a negative force is refused (the reading below the calibration's zero).
    """
    if result.value < 0:
        raise ModelDomainError(f"{name}.value", value, below)
    force, u_force = result.value, k * result.uncertainty
    for what, field, given, converted in (
        ("a force", "value", value, force),
        ("an uncertainty", "uncertainty", uncertainty, u_force),
    ):
        if not converted <= LARGEST:  # NaN too: one bound for every number (models.bounds)
            raise ModelDomainError(
                f"{name}.{field}",
                given,
                f"converts to {what} of {converted:.4g} N, beyond {LARGEST:g} N",
            )
    return Converted(force, u_force)
