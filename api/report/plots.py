"""A plan's production history as plots (charts drawn as SVG), one set per operation.

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

From :data:`DENSE_FROM` parts on (a year of parts: ``--last 1000``) the readings and the
bands after the updates are drawn as the range of each group of parts, flags still per part.

and for the plan :func:`cycle_figure`, the cycle time. The last point of every series (open
markers) is the setpoint in force: what the next part will be made with.

The ``*_figure`` functions turn the series of :mod:`api.report.series` (built from the JSON
dicts of :mod:`api.services.read`) into :class:`api.report.chart.Chart` s: what is drawn,
as data; :func:`api.report.svg.render` draws one as SVG text for the HTML report. The labels
and numbers printed on the axes are here too, and the HTML report's tables print theirs with
the same functions.

References
----------
.. [1] Ivester & Heigel, "Smart Machining Systems: Robust Optimization and Adaptive Control
   Optimization for Turning Operations" (NIST), Fig. 4 and Table 5.
"""

from __future__ import annotations

import math

import numpy as np

from api.report.chart import Chart, Mark, Panel
from api.report.series import QUANTITIES, Array, CycleSeries, OperationSeries, Output

#: Beyond this many parts the setpoint lines have no marker per part (smaller SVG).
MARKERS_UP_TO = 40
#: From this many rows on, a part is under 2.5 px wide: the readings and the bands after
#: the RCB updates are drawn as the range (lowest to highest) of each group of parts, at
#: most :data:`DENSE_GROUPS` groups, instead of a marker and a bar per part (1000 markers 5
#: px wide on 476 px are a black band). Flagged and quarantined parts keep their own marks.
DENSE_FROM, DENSE_GROUPS = 200, 160
#: The x label of every chart.
PART_AXIS = "part (in the order received; the last point: next part)"
#: Colours: the setpoint (blue), the RCB update (green), limits and flags (red), bounds (grey),
#: a sensor check (yellow), a change of the process (purple).
SETPOINT, UPDATE, ALARM, BOUND, CHECK = "#1f77b4", "#2ca02c", "#d62728", "#666666", "#ffdd00"
CHANGE = "#7b3294"
#: The legend entry of a part whose reading showed the process changed.
CHANGED = "process changed: re-learned"
#: The legend entry of the next part's open marker; in the outputs, with its band's bar.
NEXT, NEXT_BAND = "next part", "next part: predicted ± band"
#: How a limit's sense is written: "min" next to a time in minutes would read as minutes.
SENSE_WORDS = {"max": "maximum", "min": "minimum"}

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


def _x(series: OperationSeries | CycleSeries) -> Array:
    """The part numbers of the rows (the last row: the next part)."""
    return np.arange(series.first_part, series.first_part + len(series.versions), dtype=float)


def _setpoint_line(x: Array, y: Array, label: str) -> tuple[Mark, ...]:
    """Values per part (steps; markers up to :data:`MARKERS_UP_TO` parts), next part (open).

    With no part yet only the next part's marker is drawn, and only it is in the legend.
    """
    steps = Mark("steps", x, y, SETPOINT, label if len(x) > MARKERS_UP_TO else None)
    marks = [steps]
    if 1 < len(x) <= MARKERS_UP_TO:
        marks.append(Mark("points", x[:-1], y[:-1], SETPOINT, label))
    marks.append(Mark("points", x[-1:], y[-1:], SETPOINT, NEXT, marker="open"))
    return tuple(marks)


def group_size(rows: int) -> int:
    """How many parts a ``ranges`` mark groups: 1 below :data:`DENSE_FROM` rows (no grouping)."""
    return 1 if rows < DENSE_FROM else math.ceil(rows / DENSE_GROUPS)


def _ranges(x: Array, y: Array, color: str, label: str) -> Mark:
    """The lowest to the highest finite ``y`` of each :func:`group_size` parts, at their middle.

    A group with no finite value draws nothing (NaN).
    """
    size = group_size(len(x))
    starts = np.arange(0, len(x), size)
    middles = np.array([float(np.mean(x[i : i + size])) for i in starts])
    low, high = np.full(len(starts), np.nan), np.full(len(starts), np.nan)
    for k, i in enumerate(starts):
        values = y[i : i + size][np.isfinite(y[i : i + size])]
        if values.size:
            low[k], high[k] = values.min(), values.max()
    return Mark("ranges", middles, low, color, f"{label}, range of {size} parts", y2=high)


def _error_bars(x: Array, y: Array, u: Array) -> tuple[Mark, ...]:
    """Points ± u: the bars are one path, not one SVG element per bar.

    From :data:`DENSE_FROM` rows on, the range of the readings per group of parts.
    """
    if group_size(len(x)) > 1:
        return (_ranges(x, y, "#000", "measured"),)
    return (
        Mark("bars", x, y - u, "#000", "± u (measurement)", y2=y + u),
        Mark("points", x, y, "#000", "measured"),
    )


def parameters_figure(series: OperationSeries) -> Chart:
    """The cutting parameters over the parts, with their bounds (Ivester & Heigel Fig. 4a)."""
    x = _x(series)
    panels = []
    for name, values in series.parameters.items():
        bounds = series.bounds.get(name, ())
        lines = tuple(
            Mark("hline", x[:1], np.array([b]), BOUND, "bounds" if i == 0 else None, dotted=True)
            for i, b in enumerate(bounds)
        )
        panels.append(Panel(parameter_label(name), _setpoint_line(x, values, "made with") + lines))
    return Chart(f"{series.name}: cutting parameters", PART_AXIS, tuple(panels))


def limit_label(output: Output) -> str:
    """A limit's legend entry: ``limit (maximum) 2000 N``."""
    word = SENSE_WORDS[output.sense]
    return f"limit ({word}) {number(output.limit)} {unit(output.quantity)}".rstrip()


def _output_marks(x: Array, output: Output) -> tuple[Mark, ...]:
    """The prediction ± band per part (the next part's: an open marker with a bar), readings.

    The shaded band and the line step from part to part: with no part yet they would have
    no width, so they are left out; the next part's prediction and band are drawn as a
    marker and a bar, as the other plots draw the next part.
    """
    low, high = output.predicted - output.band, output.predicted + output.band
    marks = []
    if len(x) > 1:
        marks += [
            Mark("band", x, low, SETPOINT, "predicted ± band", y2=high),
            Mark("steps", x, output.predicted, SETPOINT, "predicted"),
        ]
    marks += [
        Mark("bars", x[-1:], low[-1:], SETPOINT, None, y2=high[-1:]),
        Mark("points", x[-1:], output.predicted[-1:], SETPOINT, NEXT_BAND, marker="open"),
    ]
    if np.isfinite(output.measured).any():
        marks += _error_bars(x, output.measured, output.uncertainty)
    if output.flagged.any():
        flagged = output.measured[output.flagged]
        marks.append(Mark("points", x[output.flagged], flagged, ALARM, "flagged", marker="cross"))
    if output.checked.any():  # a reading too good to be true: a check, not a flag
        checked = output.measured[output.checked]
        label = "check sensor: implausibly low"
        marks.append(Mark("points", x[output.checked], checked, CHECK, label, marker="diamond"))
    marks += _changes(x, output)
    if output.limit is not None:
        limit = np.array([output.limit])
        gid = f"limit-{output.quantity}"
        marks.append(Mark("hline", x[:1], limit, ALARM, limit_label(output), dashed=True, gid=gid))
    return tuple(marks)


def outputs_figure(series: OperationSeries) -> Chart:
    """The constrained outputs over the parts (Ivester & Heigel Fig. 4b)."""
    x = _x(series)
    panels = tuple(
        Panel(quantity_label(o.quantity), _output_marks(x, o)) for o in series.outputs
    ) or (Panel("", ()),)
    return Chart(f"{series.name}: constrained outputs", PART_AXIS, panels)


def _band_marks(x: Array, output: Output) -> tuple[Mark, ...]:
    marks = list(_setpoint_line(x, output.band, "ΔY in force (the optimiser's)"))
    dense = group_size(len(x)) > 1
    if np.isfinite(output.band_after).any():
        used = np.where(output.held, np.nan, output.band_after)
        if np.isfinite(used).any():
            after = "ΔY after the part's RCB update"
            marks.append(
                _ranges(x, used, UPDATE, "ΔY after RCB")
                if dense
                else Mark("points", x, used, UPDATE, after, marker="triangle")
            )
    if output.held.any():  # a wider band learned from few parts: not taken up
        held = np.where(output.held, output.band_after, np.nan)
        label = "ΔY learned, still wider: held"
        marks.append(
            _ranges(x, held, BOUND, "ΔY held")
            if dense
            else Mark("points", x, held, BOUND, label, marker="triangle")
        )
    if output.flagged.any():
        flagged = output.band_after[output.flagged]
        marks.append(Mark("points", x[output.flagged], flagged, ALARM, "flagged", marker="cross"))
    return (*marks, *_changes(x, output))


def _changes(x: Array, output: Output) -> tuple[Mark, ...]:
    """A dashed rule at each part whose reading showed the process changed (``regime_change``).

    Its bands widen there and it is re-learned from it: drawn at any density of parts.
    """
    if not output.changed.any():
        return ()
    at = x[output.changed]
    return (Mark("vlines", at, np.full(len(at), np.nan), CHANGE, CHANGED, dashed=True),)


def bands_figure(series: OperationSeries) -> Chart:
    """The band ΔY of each constrained output: before (at the setpoint) and after RCB."""
    x = _x(series)
    panels = tuple(
        Panel(f"band Δ {quantity_label(o.quantity)}", _band_marks(x, o), from_zero=True)
        for o in series.outputs
    ) or (Panel("", ()),)
    return Chart(f"{series.name}: uncertainty bands", PART_AXIS, panels)


def productivity_figure(series: OperationSeries) -> Chart:
    """The operation's material removal rate and machining time over the parts."""
    x = _x(series)
    panels = (
        Panel("MRR [cm³/min]", _setpoint_line(x, series.mrr_cm3_min, "made with")),
        Panel("machining time [min]", _setpoint_line(x, series.time_min, "made with")),
    )
    return Chart(f"{series.name}: productivity", PART_AXIS, panels)


def cycle_figure(series: CycleSeries) -> Chart:
    """The plan's cycle time (sum of the operations' machining times) over the parts."""
    line = _setpoint_line(_x(series), series.cycle_time_min, "made with")
    return Chart("", PART_AXIS, (Panel("cycle time [min]", line),))


#: The plots of every operation, in the order the report shows them.
OPERATION_PLOTS = {
    "parameters": parameters_figure,
    "outputs": outputs_figure,
    "bands": bands_figure,
    "productivity": productivity_figure,
}
