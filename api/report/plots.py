"""A plan's production history as plots (matplotlib figures), one set per operation.

After Ivester & Heigel [1]_, Fig. 4: (a) the input parameters and (b) the constrained outputs
of an operation, part by part, as Recursive Constraint Bounding moves the setpoint. Here, for
every operation:

- :func:`parameters_figure`: each cutting parameter over the parts, at the setpoint the part
  was made with, with its bounds (d, f, v for turning; ap, ae, fz, v for milling).
- :func:`outputs_figure`: each constrained output over the parts: the prediction ± band at
  that setpoint (shaded), the measured value ± its uncertainty (error bars), the limit
  (horizontal line), RCB decisions flagged as violations (red crosses), readings quarantined
  as implausibly low (yellow diamonds: check the sensor and the tool).
- :func:`bands_figure`: the band ΔY of each constrained output at the setpoint a part was made
  with, and the band the RCB update of that part left at the same setpoint.
- :func:`productivity_figure`: the operation's MRR and machining time.

and for the plan :func:`cycle_figure`, the cycle time. The last point of every series (open
markers) is the setpoint in force: what the next part will be made with.

The ``*_figure`` functions draw the series of :mod:`api.report.series` (built from the JSON
dicts of :mod:`api.services.queries`); :func:`api.report.svg.render` turns a figure into SVG
text for the HTML report. The labels and numbers printed on the axes are here too, and the
HTML report's tables print theirs with the same functions.

References
----------
.. [1] Ivester & Heigel, "Smart Machining Systems: Robust Optimization and Adaptive Control
   Optimization for Turning Operations" (NIST), Fig. 4 and Table 5.
"""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402 - after selecting the backend
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from api.report.series import QUANTITIES, Array, CycleSeries, OperationSeries, Output  # noqa: E402

#: Beyond this many parts the setpoint lines have no marker per part (smaller SVG).
MARKERS_UP_TO = 40
#: Width of a figure and height of one row of axes [in].
WIDTH_IN, ROW_IN = 7.5, 1.7

#: Description, symbol and unit of each cutting parameter.
PARAMETER_NAMES: dict[str, tuple[str, str, str]] = {
    "depth_mm": ("depth of cut", "d", "mm"),
    "feed_mm_rev": ("feed", "f", "mm/rev"),
    "speed_m_min": ("cutting speed", "v", "m/min"),
    "axial_depth_mm": ("axial depth", "ap", "mm"),
    "radial_depth_mm": ("radial depth", "ae", "mm"),
    "feed_per_tooth_mm": ("feed per tooth", "fz", "mm"),
}

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
    info = QUANTITIES.get(name)
    if info is None:
        return name
    return f"{info.label} [{info.unit}]"  # the quantity registry's short label


def number(value: float | None) -> str:
    """A value as printed in labels and tables: 4 significant digits, thousands separated."""
    if value is None or not math.isfinite(value):
        return "–"
    if abs(value) >= 1e4:
        return f"{value:,.0f}"
    return f"{value:.4g}"


def unit(name: str) -> str:
    """The unit of a quantity as printed (``N``, ``µm`` ...), or ``""`` if unknown."""
    info = QUANTITIES.get(name)
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
    if output.checked.any():  # a reading too good to be true: a check, not a flag
        ax.plot(
            x[output.checked],
            output.measured[output.checked],
            "D",
            markerfacecolor="#fd0",
            markeredgecolor="black",
            markersize=8,
            label="check sensor: implausibly low",
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
