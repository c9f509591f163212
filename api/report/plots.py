"""A plan's production history as plots, one set per operation, rendered as SVG text.

After Ivester & Heigel [1]_, Fig. 4: (a) the input parameters and (b) the constrained outputs
of an operation, part by part, as Recursive Constraint Bounding moves the setpoint. Here, for
every operation:

- :func:`parameters_figure`: each cutting parameter over the parts, at the setpoint the part
  was made with, with its bounds (d, f, v for turning; ap, ae, fz, v for milling).
- :func:`outputs_figure`: each constrained output over the parts: the prediction ± band at
  that setpoint (shaded), the measured value ± its uncertainty (error bars), the limit
  (horizontal line), RCB decisions flagged as violations (red crosses).
- :func:`bands_figure`: the band ΔY of each constrained output at the setpoint a part was made
  with, and the band the RCB update of that part left at the same setpoint.
- :func:`productivity_figure`: the operation's MRR and machining time.

and for the plan :func:`cycle_figure`, the cycle time. The last point of every series (open
markers) is the setpoint in force: what the next part will be made with.

The data come as the JSON dicts of :mod:`api.services.queries` (``get_plan``, ``plan_history`` and
the items of ``parts``); :func:`operation_series` and :func:`cycle_series` turn them into arrays,
the ``*_figure`` functions draw those, and :func:`to_svg` renders a figure as SVG text that is
deterministic (fixed ``svg.hashsalt``, no date) and small (text kept as text, ``svg.fonttype =
"none"``); ``id_prefix`` makes its ids unique within an HTML page.

References
----------
.. [1] Ivester & Heigel, "Smart Machining Systems: Robust Optimization and Adaptive Control
   Optimization for Turning Operations" (NIST), Fig. 4 and Table 5.
"""

from __future__ import annotations

import io
import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeVar

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402 - after selecting the backend
import numpy.typing as npt  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from models.kinematics import PARAMETERS  # noqa: E402
from models.quantities import DERIVED_QUANTITIES, MODEL_QUANTITIES, PARTS_PER_EDGE  # noqa: E402

if TYPE_CHECKING:
    from matplotlib.typing import RcKeyType  # matplotlib >= 3.10; only for the checker

Array = npt.NDArray[np.float64]
S = TypeVar("S")

#: Style of every figure: text stays text in the SVG, ids do not change from run to run.
STYLE: dict[RcKeyType, Any] = {
    "svg.fonttype": "none",
    "svg.hashsalt": "rcb-report",
    "font.size": 8.0,
    "font.family": "sans-serif",
    "font.sans-serif": ["DejaVu Sans", "Arial", "Helvetica"],  # named in every SVG text
    "axes.grid": True,
    "grid.alpha": 0.3,
    "lines.markersize": 4.0,
}
#: Beyond this many parts the setpoint lines have no marker per part (smaller SVG).
MARKERS_UP_TO = 40
#: Width of a figure and height of one row of axes [in].
WIDTH_IN, ROW_IN = 7.5, 1.7
_SVG_METADATA: dict[str, Any] = {"Creator": None, "Date": None, "Format": None, "Type": None}

#: Description, symbol and unit of each cutting parameter.
PARAMETER_NAMES: dict[str, tuple[str, str, str]] = {
    "depth_mm": ("depth of cut", "d", "mm"),
    "feed_mm_rev": ("feed", "f", "mm/rev"),
    "speed_m_min": ("cutting speed", "v", "m/min"),
    "axial_depth_mm": ("axial depth", "ap", "mm"),
    "radial_depth_mm": ("radial depth", "ae", "mm"),
    "feed_per_tooth_mm": ("feed per tooth", "fz", "mm"),
}
_SHORT_NAMES = {
    "force_N": "force F",
    "roughness_um": "roughness Ra",
    "tool_life_mm3": "tool life",
    "spindle_current_A": "spindle current",
    "power_kW": "power",
    "torque_Nm": "torque",
    "spindle_rpm": "spindle speed",
    "feed_rate_mm_min": "feed rate",
}
_QUANTITIES = {**MODEL_QUANTITIES, **DERIVED_QUANTITIES}


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


# --------------------------------------------------------------------------------------------
# from the query dicts to arrays


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
    for key, limit in plan["machine_limits"].items():
        quantity = key.removeprefix("max_")
        if quantity in binding and quantity not in out and limit is not None:
            out[quantity] = (float(limit), "max")
    for quantity in sorted(measured - set(out)):
        out[quantity] = (None, _QUANTITIES[quantity].sense if quantity in _QUANTITIES else "max")
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
    return Output(
        quantity=quantity,
        limit=limit[0],
        sense=limit[1],
        predicted=_values(predicted, "value"),
        band=_values(predicted, "band"),
        measured=_values(measured, "value"),
        uncertainty=_values(measured, "uncertainty"),
        band_after=_values(decided, "band_after"),
        flagged=np.array([bool(d and d["flagged"]) for d in decided], dtype=bool),
    )


def operation_series(
    plan: Mapping[str, Any],
    history: Mapping[str, Any],
    parts: Sequence[Mapping[str, Any]],
    operation: str,
    first_part: int = 1,
) -> OperationSeries:
    """The arrays the plots of ``operation`` show, from the :mod:`api.services.queries` dicts.

    Parameters
    ----------
    plan : Mapping
        :func:`api.services.queries.get_plan`: the operations with their limits and bounds.
    history : Mapping
        :func:`api.services.queries.plan_history`: every setpoint version.
    parts : Sequence of Mapping
        The items of :func:`api.services.queries.parts`, oldest first (all pages).
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
    measured = {q for m in measurements for q in m}
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


# --------------------------------------------------------------------------------------------
# labels


def parameter_label(name: str) -> str:
    """Axis label of a cutting parameter, with its unit: ``feed f [mm/rev]``."""
    if name not in PARAMETER_NAMES:
        return name
    description, symbol, symbol_unit = PARAMETER_NAMES[name]
    return f"{description} {symbol} [{symbol_unit}]"


def parameter_value(name: str, value: float) -> str:
    """A cutting parameter's value with its symbol and unit: ``f = 0.32 mm/rev``."""
    if name not in PARAMETER_NAMES:
        return f"{name} = {number(value)}"
    _, symbol, symbol_unit = PARAMETER_NAMES[name]
    return f"{symbol} = {number(value)} {symbol_unit}"


def quantity_label(name: str) -> str:
    """Axis label of a predicted or measured quantity, with its unit."""
    info = _QUANTITIES.get(name)
    if info is None:
        return name
    return f"{_SHORT_NAMES.get(name, info.description)} [{info.unit}]"


def number(value: float | None) -> str:
    """A value as printed in labels and tables: 4 significant digits, thousands separated."""
    if value is None or not math.isfinite(value):
        return "–"
    if abs(value) >= 1e4:
        return f"{value:,.0f}"
    return f"{value:.4g}"


def unit(name: str) -> str:
    """The unit of a quantity as printed (``N``, ``µm`` ...), or ``""`` if unknown."""
    info = _QUANTITIES.get(name)
    return info.unit if info else ""


# --------------------------------------------------------------------------------------------
# drawing


def _figure(rows: int) -> tuple[Figure, list[Axes]]:
    """A figure of ``rows`` axes sharing the part axis (no pyplot: no global figure list)."""
    figure = Figure(figsize=(WIDTH_IN, 0.6 + ROW_IN * rows), layout="constrained")
    axes = figure.subplots(rows, 1, sharex=True, squeeze=False)[:, 0]
    for ax in axes:
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    axes[-1].set_xlabel("part (in the order received; the last point: next part)")
    return figure, list(axes)


def _x(series: OperationSeries | CycleSeries) -> Array:
    """The part numbers of the rows (the last row: the next part)."""
    return np.arange(series.first_part, series.first_part + len(series.versions), dtype=float)


def _legend(ax: Axes) -> None:
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small", frameon=False)


def _setpoint_line(ax: Axes, x: Array, y: Array, label: str) -> None:
    """Values per part (steps; markers up to :data:`MARKERS_UP_TO` parts), next part (open)."""
    if len(x) > MARKERS_UP_TO:
        ax.plot(x, y, drawstyle="steps-mid", color="C0", linewidth=1.0, label=label)
    else:
        ax.plot(x, y, drawstyle="steps-mid", color="C0", linewidth=1.0)
        ax.plot(x[:-1], y[:-1], "o", color="C0", label=label)
    ax.plot(x[-1:], y[-1:], "o", color="C0", markerfacecolor="white", label="next part")


def _error_bars(ax: Axes, x: Array, y: Array, u: Array) -> None:
    """Points ± u; the bars are one path (NaN-separated), not one SVG element per bar."""
    bars = np.column_stack([y - u, y + u, np.full_like(y, np.nan)]).ravel()
    ax.plot(np.repeat(x, 3), bars, color="k", linewidth=1.0, label="± u (measurement)")
    ax.plot(x, y, "o", color="k", markersize=3.0, label="measured")


def parameters_figure(series: OperationSeries) -> Figure:
    """The cutting parameters over the parts, with their bounds (Ivester & Heigel Fig. 4a)."""
    figure, axes = _figure(len(series.parameters))
    x = _x(series)
    for ax, (name, values) in zip(axes, series.parameters.items(), strict=True):
        _setpoint_line(ax, x, values, "made with")
        for bound in series.bounds.get(name, ()):
            ax.axhline(bound, color="0.4", linestyle=":", linewidth=1.0)
        ax.plot([], [], color="0.4", linestyle=":", label="bounds")
        ax.set_ylabel(parameter_label(name))
        _legend(ax)
    figure.suptitle(f"{series.name}: cutting parameters", fontsize="medium", parse_math=False)
    return figure


def _limit_line(ax: Axes, output: Output) -> None:
    if output.limit is None:
        return
    word = "max" if output.sense == "max" else "min"
    line = ax.axhline(output.limit, color="C3", linestyle="--", linewidth=1.2)
    line.set_label(f"limit ({word}) {number(output.limit)} {unit(output.quantity)}")
    line.set_gid(f"limit-{output.quantity}")


def _output_axes(ax: Axes, x: Array, output: Output) -> None:
    low, high = output.predicted - output.band, output.predicted + output.band
    ax.fill_between(x, low, high, step="mid", color="C0", alpha=0.2, label="predicted ± band")
    ax.plot(x, output.predicted, drawstyle="steps-mid", color="C0", label="predicted")
    if np.isfinite(output.measured).any():
        _error_bars(ax, x, output.measured, output.uncertainty)
    if output.flagged.any():
        ax.plot(
            x[output.flagged],
            output.measured[output.flagged],
            "x",
            color="C3",
            markersize=9,
            markeredgewidth=2,
            label="flagged",
        )
    _limit_line(ax, output)
    ax.set_ylabel(quantity_label(output.quantity), parse_math=False)
    _legend(ax)


def outputs_figure(series: OperationSeries) -> Figure:
    """The constrained outputs over the parts (Ivester & Heigel Fig. 4b)."""
    figure, axes = _figure(max(len(series.outputs), 1))
    x = _x(series)
    for ax, output in zip(axes, series.outputs, strict=False):
        _output_axes(ax, x, output)
    figure.suptitle(f"{series.name}: constrained outputs", fontsize="medium", parse_math=False)
    return figure


def bands_figure(series: OperationSeries) -> Figure:
    """The band ΔY of each constrained output: before (at the setpoint) and after RCB."""
    figure, axes = _figure(max(len(series.outputs), 1))
    x = _x(series)
    for ax, output in zip(axes, series.outputs, strict=False):
        _setpoint_line(ax, x, output.band, "at the setpoint made with")
        if np.isfinite(output.band_after).any():
            ax.plot(x, output.band_after, "v", color="C2", label="after the part's RCB update")
        if output.flagged.any():
            ax.plot(
                x[output.flagged],
                output.band_after[output.flagged],
                "x",
                color="C3",
                markersize=9,
                markeredgewidth=2,
                label="flagged",
            )
        ax.set_ylim(bottom=0.0)
        ax.set_ylabel(f"band Δ {quantity_label(output.quantity)}", parse_math=False)
        _legend(ax)
    figure.suptitle(f"{series.name}: uncertainty bands", fontsize="medium", parse_math=False)
    return figure


def productivity_figure(series: OperationSeries) -> Figure:
    """The operation's material removal rate and machining time over the parts."""
    figure, (mrr, time) = _figure(2)
    x = _x(series)
    _setpoint_line(mrr, x, series.mrr_cm3_min, "made with")
    mrr.set_ylabel("MRR [cm³/min]")
    _setpoint_line(time, x, series.time_min, "made with")
    time.set_ylabel("machining time [min]")
    for ax in (mrr, time):
        _legend(ax)
    figure.suptitle(f"{series.name}: productivity", fontsize="medium", parse_math=False)
    return figure


def cycle_figure(series: CycleSeries) -> Figure:
    """The plan's cycle time (sum of the operations' machining times) over the parts."""
    figure, (ax,) = _figure(1)
    _setpoint_line(ax, _x(series), series.cycle_time_min, "made with")
    ax.set_ylabel("cycle time [min]")
    _legend(ax)
    return figure


#: The plots of every operation, in the order the report shows them.
OPERATION_PLOTS = {
    "parameters": parameters_figure,
    "outputs": outputs_figure,
    "bands": bands_figure,
    "productivity": productivity_figure,
}


# --------------------------------------------------------------------------------------------
# SVG

_ID = re.compile(r'(\bid="|href="#|url\(#)')
_ID_ATTRIBUTE = re.compile(r' id="([^"]*)"')
_REFERENCE = re.compile(r'(?:href="#|url\(#)([^")]*)')


def to_svg(figure: Figure, id_prefix: str = "") -> str:
    """The figure as an SVG element (no XML declaration or DOCTYPE), compact, ids prefixed.

    Matplotlib's own group ids (``line2d_7`` ...) that nothing refers to are dropped, and so
    is the indentation; ids set on artists (``set_gid``) and referenced ids (markers, clip
    paths) stay, with ``id_prefix`` before them.

    Parameters
    ----------
    figure : Figure
        Drawn under :data:`STYLE` (see :func:`render`).
    id_prefix : str
        Put before every id and reference to one, so that several SVGs in one HTML page
        have unique ids; letters, digits, ``-`` and ``_`` only.
    """
    if not re.fullmatch(r"[A-Za-z0-9_-]*", id_prefix):
        raise ValueError(f"id_prefix = {id_prefix!r}: letters, digits, - and _ only")
    buffer = io.StringIO()
    with matplotlib.rc_context(STYLE):
        figure.savefig(buffer, format="svg", metadata=_SVG_METADATA)
    text = buffer.getvalue()
    text = re.sub(r"\n +", "\n", text[text.index("<svg") :].strip())
    kept = set(_REFERENCE.findall(text)) | {a.get_gid() for a in figure.findobj() if a.get_gid()}
    text = _ID_ATTRIBUTE.sub(lambda m: m.group(0) if m.group(1) in kept else "", text)
    return _ID.sub(lambda m: f"{m.group(1)}{id_prefix}-", text) if id_prefix else text


def render(draw: Callable[[S], Figure], series: S, id_prefix: str = "") -> str:
    """Draw ``series`` with ``draw`` (a ``*_figure`` function) under :data:`STYLE`, as SVG."""
    with matplotlib.rc_context(STYLE):
        return to_svg(draw(series), id_prefix)
