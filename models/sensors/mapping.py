"""Plan-file readers and writers of the sensor calibrations (format: :mod:`models.sensors`).

One reader per kind: ``ivester_spindle_load`` (Ivester & Heigel Eqs. 1-4),
``linear_current`` and ``linear_current_by_feed`` (Kim & Jeon §6.2.3) and
``tai_current_feed`` (Tai, Tsai & Li Eq. 14); :func:`calibration_from_mapping` dispatches on
``kind`` and :func:`calibration_to_mapping` writes any of them back.
"""

from __future__ import annotations

import datetime
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from models import fields
from models.bounds import MAX_CALIBRATIONS, check_count
from models.errors import InputError
from models.sensors.convert import Calibration
from models.sensors.ivester import IvesterSpindleLoadCalibration
from models.sensors.kim_jeon import LinearCurrentCalibration
from models.sensors.kim_jeon_feed import FeedDependentCurrentCalibration
from models.sensors.tai import _TAI_CORR, _TAI_PARAMS, TaiCurrentFeedCalibration

_PROVENANCE = ("source", "reference", "date", "notes")
_IVESTER_NUMBERS = (
    "m_low_N_mm_per_V",
    "m_coefficient",
    "m_exponent",
    "corner_speed_rad_s",
    "u_m_N_mm_per_V",
    "u_idle_load_V",
)
_LINEAR_NUMBERS = (
    "offset_N",
    "slope_N_per_A",
    "u_offset_N",
    "u_slope_N_per_A",
    "corr_offset_slope",
    "residual_sd_N",
)
_SPEED_FIELDS = ("spindle_speed_rpm", "speed_tolerance_rel")
_TAI_NUMBERS = (
    *_TAI_PARAMS,
    *(f"u_{p}" for p in _TAI_PARAMS),
    *_TAI_CORR.values(),
    "residual_sd_A",
)


def _provenance(data: Mapping[str, Any], path: str, *, source_required: bool) -> dict[str, str]:
    result: dict[str, str] = {}
    for key in _PROVENANCE:
        if key not in data:
            if key == "source" and source_required:
                raise InputError(f"{path}.source", None, "required field missing")
            continue
        value = data[key]
        if key == "date" and isinstance(value, datetime.date):
            value = value.isoformat()
        result[key] = fields.text({key: value}, key, path)
    return result


def _read(
    data: Mapping[str, Any], keys: Iterable[str], path: str, cls: type[Any], **extra: object
) -> Any:
    """Build ``cls`` from the numeric ``keys`` present in ``data``, naming ``path`` in errors."""
    kwargs: dict[str, object] = dict(extra)
    for key in keys:
        if key in data:
            kwargs[key] = fields.number(data[key], f"{path}.{key}")
    if "n" in data:
        n = data["n"]
        if isinstance(n, bool) or not isinstance(n, int) or n < 0:
            raise InputError(f"{path}.n", n, "must be a whole number >= 0")
        kwargs["n"] = n
    try:
        return cls(**kwargs)
    except InputError as exc:
        raise InputError(f"{path}.{exc.field}", exc.value, exc.reason) from exc


def _check_kind(data: Mapping[str, Any], path: str, expected: str) -> None:
    kind = fields.text(data, "kind", path)
    if kind != expected:
        raise InputError(f"{path}.kind", kind, f"expected {expected!r}")


def ivester_calibration_from_mapping(data: object, path: str) -> IvesterSpindleLoadCalibration:
    """Read an ``ivester_spindle_load`` calibration (format in the module docstring).

    Parameters
    ----------
    data : object
        The table, as parsed from TOML or JSON.
    path : str
        Its dotted path, for errors (e.g. ``machine.calibrations.spindle_load``).

    Returns
    -------
    IvesterSpindleLoadCalibration
        The calibration; constants not given keep the paper's values.
    """
    table = fields.mapping(data, path)
    allowed = ("kind", *_PROVENANCE, *_IVESTER_NUMBERS, "idle_speeds_rpm", "idle_loads_V")
    fields.only_keys(table, allowed, path)
    _check_kind(table, path, IvesterSpindleLoadCalibration.kind)
    extra: dict[str, object] = dict(_provenance(table, path, source_required=True))
    for key in ("idle_speeds_rpm", "idle_loads_V"):
        if key in table:
            extra[key] = fields.number_list(table[key], f"{path}.{key}")
    if ("idle_speeds_rpm" in table) != ("idle_loads_V" in table):
        missing = "idle_loads_V" if "idle_speeds_rpm" in table else "idle_speeds_rpm"
        raise InputError(f"{path}.{missing}", None, "required with the other idle-load list")
    result: IvesterSpindleLoadCalibration = _read(
        table, _IVESTER_NUMBERS, path, IvesterSpindleLoadCalibration, **extra
    )
    return result


def _linear_fields(table: Mapping[str, Any], path: str) -> dict[str, object]:
    extra: dict[str, object] = {}
    for key in ("feed_rate_mm_min", *_SPEED_FIELDS):
        if key in table:
            extra[key] = fields.number(table[key], f"{path}.{key}")
    for key in ("offset_N", "slope_N_per_A"):
        if key not in table:
            raise InputError(f"{path}.{key}", None, "required field missing")
    return extra


def linear_current_calibration_from_mapping(data: object, path: str) -> LinearCurrentCalibration:
    """Read a ``linear_current`` calibration (format in the module docstring).

    Parameters
    ----------
    data : object
        The table, as parsed from TOML or JSON.
    path : str
        Its dotted path, for errors.

    Returns
    -------
    LinearCurrentCalibration
        The calibration.
    """
    table = fields.mapping(data, path)
    allowed = ("kind", *_PROVENANCE, *_LINEAR_NUMBERS, "n", "feed_rate_mm_min", *_SPEED_FIELDS)
    fields.only_keys(table, allowed, path)
    _check_kind(table, path, LinearCurrentCalibration.kind)
    extra = _linear_fields(table, path)
    extra.update(_provenance(table, path, source_required=True))
    result: LinearCurrentCalibration = _read(
        table, _LINEAR_NUMBERS, path, LinearCurrentCalibration, **extra
    )
    return result


def feed_dependent_calibration_from_mapping(
    data: object, path: str
) -> FeedDependentCurrentCalibration:
    """Read a ``linear_current_by_feed`` calibration (format in the module docstring).

    Parameters
    ----------
    data : object
        The table, as parsed from TOML or JSON.
    path : str
        Its dotted path, for errors.

    Returns
    -------
    FeedDependentCurrentCalibration
        The calibration.
    """
    table = fields.mapping(data, path)
    fields.only_keys(table, ("kind", *_PROVENANCE, *_SPEED_FIELDS, "points"), path)
    _check_kind(table, path, FeedDependentCurrentCalibration.kind)
    if "points" not in table:
        raise InputError(f"{path}.points", None, "required field missing")
    raw_points = table["points"]
    if isinstance(raw_points, str | bytes | Mapping) or not isinstance(raw_points, Sequence):
        raise InputError(f"{path}.points", raw_points, "must be a list of tables")
    points = []
    for i, item in enumerate(raw_points):
        where = f"{path}.points[{i}]"
        point = fields.mapping(item, where)
        fields.only_keys(point, (*_LINEAR_NUMBERS, "n", "feed_rate_mm_min"), where)
        if "feed_rate_mm_min" not in point:
            raise InputError(f"{where}.feed_rate_mm_min", None, "required field missing")
        points.append(
            _read(
                point,
                _LINEAR_NUMBERS,
                where,
                LinearCurrentCalibration,
                **_linear_fields(point, where),
            )
        )
    provenance = _provenance(table, path, source_required=True)
    result: FeedDependentCurrentCalibration = _read(
        table,
        _SPEED_FIELDS,
        path,
        FeedDependentCurrentCalibration,
        points=tuple(points),
        **provenance,
    )
    return result


def tai_calibration_from_mapping(data: object, path: str) -> TaiCurrentFeedCalibration:
    """Read a ``tai_current_feed`` calibration (format in the module docstring).

    Parameters
    ----------
    data : object
        The table, as parsed from TOML or JSON.
    path : str
        Its dotted path, for errors.

    Returns
    -------
    TaiCurrentFeedCalibration
        The calibration.
    """
    table = fields.mapping(data, path)
    fields.only_keys(table, ("kind", *_PROVENANCE, *_TAI_NUMBERS, "n"), path)
    _check_kind(table, path, TaiCurrentFeedCalibration.kind)
    for key in ("idle_current_A", "slope_A_per_mm_min"):
        if key not in table:
            raise InputError(f"{path}.{key}", None, "required field missing")
    extra = _provenance(table, path, source_required=True)
    result: TaiCurrentFeedCalibration = _read(
        table, _TAI_NUMBERS, path, TaiCurrentFeedCalibration, **extra
    )
    return result


_READERS = {
    IvesterSpindleLoadCalibration.kind: ivester_calibration_from_mapping,
    LinearCurrentCalibration.kind: linear_current_calibration_from_mapping,
    FeedDependentCurrentCalibration.kind: feed_dependent_calibration_from_mapping,
    TaiCurrentFeedCalibration.kind: tai_calibration_from_mapping,
}

#: Calibration kinds the plan file may name.
CALIBRATION_KINDS: tuple[str, ...] = tuple(_READERS)


def calibration_from_mapping(data: object, path: str) -> Calibration:
    """Read one calibration of any kind, dispatching on its ``kind`` field.

    Parameters
    ----------
    data : object
        The table, as parsed from TOML or JSON.
    path : str
        Its dotted path, for errors (e.g. ``machine.calibrations.spindle_load``).

    Returns
    -------
    Calibration
        The calibration.

    Raises
    ------
    InputError
        Naming the field: ``{path}.kind`` when the kind is missing or unknown.
    """
    table = fields.mapping(data, path)
    kind = fields.text(table, "kind", path)
    if kind not in _READERS:
        raise InputError(
            f"{path}.kind",
            kind,
            f"unknown calibration kind; expected one of: {', '.join(_READERS)}",
        )
    reader: Any = _READERS[kind]
    result: Calibration = reader(table, path)
    return result


def calibrations_from_mapping(data: object, path: str) -> dict[str, Calibration]:
    """Read a table of named calibrations (``[machine.calibrations]``).

    Parameters
    ----------
    data : object
        The table, as parsed from TOML or JSON.
    path : str
        Its dotted path, for errors (e.g. ``machine.calibrations``).

    Returns
    -------
    dict of str to Calibration
        The calibrations by name; at most :data:`models.bounds.MAX_CALIBRATIONS`, counted
        before any is read.
    """
    table = fields.mapping(data, path)
    check_count(len(table), MAX_CALIBRATIONS, path, "calibrations")
    return {
        name: calibration_from_mapping(value, f"{path}.{name}") for name, value in table.items()
    }


def _linear_to_mapping(cal: LinearCurrentCalibration, *, point: bool) -> dict[str, object]:
    out: dict[str, object] = {} if point else {"kind": cal.kind}
    out.update({key: getattr(cal, key) for key in _LINEAR_NUMBERS})
    out["n"] = cal.n
    if cal.feed_rate_mm_min is not None:
        out["feed_rate_mm_min"] = cal.feed_rate_mm_min
    if not point:
        if cal.spindle_speed_rpm is not None:
            out["spindle_speed_rpm"] = cal.spindle_speed_rpm
        out["speed_tolerance_rel"] = cal.speed_tolerance_rel
    return out


def calibration_to_mapping(calibration: Calibration) -> dict[str, object]:
    """The plan-file table of a calibration (``calibration_from_mapping`` reads it back).

    Parameters
    ----------
    calibration : Calibration
        Any calibration of this module.

    Returns
    -------
    dict
        JSON- and TOML-ready table with ``kind``, every number and the non-empty provenance.
        Speeds and tolerances of the points of a ``linear_current_by_feed`` calibration are
        not written (the calibration's own are).
    """
    out: dict[str, object]
    if isinstance(calibration, IvesterSpindleLoadCalibration):
        out = {"kind": calibration.kind}
        out.update({key: getattr(calibration, key) for key in _IVESTER_NUMBERS})
        if calibration.idle_speeds_rpm:
            out["idle_speeds_rpm"] = list(calibration.idle_speeds_rpm)
            out["idle_loads_V"] = list(calibration.idle_loads_V)
    elif isinstance(calibration, LinearCurrentCalibration):
        out = _linear_to_mapping(calibration, point=False)
    elif isinstance(calibration, FeedDependentCurrentCalibration):
        out = {"kind": calibration.kind}
        if calibration.spindle_speed_rpm is not None:
            out["spindle_speed_rpm"] = calibration.spindle_speed_rpm
        out["speed_tolerance_rel"] = calibration.speed_tolerance_rel
        out["points"] = [_linear_to_mapping(p, point=True) for p in calibration.points]
    else:
        out = {"kind": calibration.kind}
        out.update({key: getattr(calibration, key) for key in _TAI_NUMBERS})
        out["n"] = calibration.n
    for key in _PROVENANCE:
        if getattr(calibration, key):
            out[key] = getattr(calibration, key)
    return out
