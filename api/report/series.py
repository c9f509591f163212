"""A plan's history as arrays for its plots: per operation, and the plan's cycle time.

The data come as the JSON dicts of :mod:`api.services.read` (``get_plan``, ``plan_history``
and the items of ``parts``); :func:`operation_series` and :func:`cycle_series` turn them into
frozen series whose rows are the parts, at the setpoint each was made with, then the setpoint in
force (what the next part will be made with). :mod:`api.report.plots` draws them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from api.services.read.record import TOOL_CHANGE
from models import quantities
from models.kinematics import PARAMETERS
from models.quantities import PARTS_PER_EDGE

Array = npt.NDArray[np.float64]

#: Every quantity a plot may show (predicted or measured), by name.
QUANTITIES = quantities.QUANTITIES
#: The note of a reading quarantined as implausibly low (supervisor.rcb.state.Note), marked apart.
CHECKED = "implausible_low"
#: The note of a decision that saw the process change (supervisor.rcb.state.Note).
CHANGED = "regime_change"


@dataclass(frozen=True)
class Output:
    """One constrained output of an operation, per row (the parts, then the next setpoint).

    Parameters
    ----------
    quantity : str
        Quantity name with its unit (``force_N`` ...).
    limit : float or None
        The allowable maximum (or minimum, ``sense == "min"``) [unit of the quantity].
    sense : {"max", "min"}
        Whether the limit is a maximum or a minimum.
    predicted, band : ndarray
        Prediction and its band ΔY at the setpoint of the row (NaN if not predicted).
    measured, uncertainty : ndarray
        Measurement and its uncertainty u (NaN where not measured, always at the last row).
    band_after : ndarray
        Band after the RCB update of the row's part, at the same setpoint (NaN: no decision).
    flagged : ndarray of bool
        The RCB decision flagged a violation (measurement outside the band or over the limit).
    checked : ndarray of bool
        The RCB decision quarantined the reading as implausibly low (note ``implausible_low``:
        the operator checks the sensor and the tool).
    held : ndarray of bool
        The RCB decision held the band in force although the band it computed is wider (action
        ``hold``, ``band_after > band``: a model learned from few parts, not taken up).
    changed : ndarray of bool
        The RCB decision saw the process change (note ``regime_change``): the quantity is
        re-learned from that part on.
    """

    quantity: str
    limit: float | None
    sense: str
    predicted: Array
    band: Array
    measured: Array
    uncertainty: Array
    band_after: Array
    flagged: npt.NDArray[np.bool_]
    checked: npt.NDArray[np.bool_]
    held: npt.NDArray[np.bool_]
    changed: npt.NDArray[np.bool_]


@dataclass(frozen=True)
class OperationSeries:
    """What the plots of one operation show, per row: the parts, then the setpoint in force.

    Row ``i < n`` is part ``i + 1`` at the setpoint it was made with; the last row is the
    setpoint the next part will be made with.

    Parameters
    ----------
    name, tool, process : str
        The operation, its tool and its process (``turning``, ``milling``).
    serials : tuple of str
        The parts' serial numbers, in the order received.
    versions : tuple of int
        Setpoint version of each row (the one the part was made with; then the one in force).
    parameters : dict of str to ndarray
        Each cutting parameter per row [its unit].
    bounds : dict of str to tuple of float
        ``(low, high)`` of each parameter.
    outputs : tuple of Output
        The constrained outputs.
    mrr_cm3_min, time_min : ndarray
        Material removal rate [cm³/min] and machining time [min] per row.
    first_part : int
        Number of the first row's part (1 unless only the last parts are shown).
    """

    name: str
    tool: str
    process: str
    serials: tuple[str, ...]
    versions: tuple[int, ...]
    parameters: dict[str, Array]
    bounds: dict[str, tuple[float, float]]
    outputs: tuple[Output, ...]
    mrr_cm3_min: Array
    time_min: Array
    first_part: int = 1


@dataclass(frozen=True)
class CycleSeries:
    """The plan's cycle time [min] per row (the parts, then the setpoint in force)."""

    serials: tuple[str, ...]
    versions: tuple[int, ...]
    cycle_time_min: Array
    first_part: int = 1


def _rows(
    history: Mapping[str, Any], parts: Sequence[Mapping[str, Any]]
) -> tuple[tuple[str, ...], tuple[int, ...], dict[int, Mapping[str, Any]]]:
    """Serials, the setpoint version of every row, and the versions by number."""
    by_number = {v["version"]: v for v in history["versions"]}
    versions = (*(int(p["setpoint_version"]) for p in parts), max(by_number))
    return tuple(str(p["serial"]) for p in parts), versions, by_number


def cycle_series(
    history: Mapping[str, Any], parts: Sequence[Mapping[str, Any]], first_part: int = 1
) -> CycleSeries:
    """The plan's cycle time at the setpoint each part was made with, then the one in force."""
    serials, versions, by_number = _rows(history, parts)
    cycle = np.array([by_number[v]["cycle_time_min"] for v in versions], dtype=float)
    return CycleSeries(serials, versions, cycle, first_part)


def constrained_quantities(
    operation: Mapping[str, Any],
    plan: Mapping[str, Any],
    setpoints: Sequence[Mapping[str, Any]],
    measured: set[str],
) -> dict[str, tuple[float | None, str]]:
    """The outputs to plot with their limit and sense.

    The operation's own limits (``parts_per_edge`` as the tool life it requires,
    parts × volume [mm³], a minimum), the machine limits that bind at some setpoint version
    of the operation, and every measured quantity (with its limit if it has one).
    """
    out: dict[str, tuple[float | None, str]] = {}
    for key, limit in operation["limits"].items():
        if key == PARTS_PER_EDGE:
            out["tool_life_mm3"] = (float(limit) * float(operation["volume_mm3"]), "min")
        else:
            out[key] = (float(limit), "max")
    binding = {name for sp in setpoints for name in sp["binding"]}
    bounds = quantities.machine_fields()
    for key, limit in plan["machine_limits"].items():
        quantity = bounds[key]
        if quantity in binding and quantity not in out and limit is not None:
            out[quantity] = (float(limit), "max")
    for quantity in sorted(measured - set(out)):
        out[quantity] = (None, QUANTITIES[quantity].sense if quantity in QUANTITIES else "max")
    return out


def _values(rows: Sequence[Mapping[str, Any] | None], key: str) -> Array:
    return np.array([math.nan if r is None or key not in r else r[key] for r in rows], dtype=float)


def _output(
    quantity: str,
    limit: tuple[float | None, str],
    setpoints: Sequence[Mapping[str, Any]],
    measurements: Sequence[Mapping[str, Any]],
    decisions: Sequence[Mapping[str, Any]],
) -> Output:
    predicted = [sp["predicted"].get(quantity) for sp in setpoints]
    measured = [*(m.get(quantity) for m in measurements), None]
    decided = [*(d.get(quantity) for d in decisions), None]
    band, band_after = _values(predicted, "band"), _values(decided, "band_after")
    hold = np.array([bool(d and d["action"] == "hold") for d in decided], dtype=bool)
    return Output(
        quantity=quantity,
        limit=limit[0],
        sense=limit[1],
        predicted=_values(predicted, "value"),
        band=band,
        measured=_values(measured, "value"),
        uncertainty=_values(measured, "uncertainty"),
        band_after=band_after,
        flagged=np.array([bool(d and d["flagged"]) for d in decided], dtype=bool),
        checked=np.array([bool(d and d.get("note") == CHECKED) for d in decided], dtype=bool),
        held=hold & (band_after > band),
        changed=np.array([bool(d and d.get("note") == CHANGED) for d in decided], dtype=bool),
    )


def operation_series(
    plan: Mapping[str, Any],
    history: Mapping[str, Any],
    parts: Sequence[Mapping[str, Any]],
    operation: str,
    first_part: int = 1,
) -> OperationSeries:
    """The arrays the plots of ``operation`` show, from the :mod:`api.services.read` dicts.

    Parameters
    ----------
    plan : Mapping
        :func:`api.services.read.plans.get_plan`: the operations with their limits and bounds.
    history : Mapping
        :func:`api.services.read.history.plan_history`: every setpoint version.
    parts : Sequence of Mapping
        The items of :func:`api.services.read.plan_parts.parts`, oldest first (all pages).
    operation : str
        The operation's name.
    first_part : int
        Number of the first of ``parts`` (when they are the last of more parts).
    """
    op = next(o for o in plan["operations"] if o["name"] == operation)
    serials, versions, by_number = _rows(history, parts)
    setpoints = [
        next(o for o in by_number[v]["operations"] if o["name"] == operation) for v in versions
    ]
    measurements: list[Mapping[str, Any]] = [
        next((o["measurements"] for o in p["operations"] if o["name"] == operation), {})
        for p in parts
    ]
    decisions = [
        {d["quantity"]: d for d in p["updates"] if d["operation"] == operation} for p in parts
    ]
    # a feed override is no constrained output: the tool-change table shows it
    measured = {q for m in measurements for q in m if q != TOOL_CHANGE}
    limits = constrained_quantities(op, plan, setpoints, measured)
    names = PARAMETERS.get(op["process"], tuple(setpoints[-1]["setpoint"]))
    return OperationSeries(
        name=operation,
        tool=str(op["tool"]),
        process=str(op["process"]),
        serials=serials,
        versions=versions,
        parameters={n: _values([sp["setpoint"] for sp in setpoints], n) for n in names},
        bounds={n: (float(lo), float(hi)) for n, (lo, hi) in op["bounds"].items()},
        outputs=tuple(
            _output(q, limit, setpoints, measurements, decisions) for q, limit in limits.items()
        ),
        mrr_cm3_min=_values(setpoints, "mrr_cm3_min"),
        time_min=_values(setpoints, "time_min"),
        first_part=first_part,
    )
