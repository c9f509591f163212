"""A plan's production record as one self-contained HTML page an engineer can mail.

:func:`render_record` takes the record of :func:`api.services.read.record.report_record` (bounded:
the last parts, the newest setpoint versions, totals and summaries from SQL) and returns the
page: the setpoints in force with their bands and margins, the setpoint versions with their
cause and MRR (older ones summarised), the tool changes called for, the cycle time, and per
operation the plots of :mod:`api.report.plots` (after Ivester & Heigel, Fig. 4).
:func:`render_html_report` does the same from complete lists (:mod:`api.report.full_record`).

Self-contained: CSS and SVG are inline; nothing is loaded from elsewhere, no script runs. The
only URIs in the page are the XML namespace names the inline SVGs declare
(``http://www.w3.org/2000/svg``, ``http://www.w3.org/1999/xlink``), which identify and fetch
nothing. Every piece of text from the database is escaped (:func:`html.escape`); the page is
also well-formed XML, so XML tools can read it.
"""

from __future__ import annotations

import html
import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

from api.report import plots
from api.report.full_record import full_record
from api.report.html_history import history_table, mark, tool_change_table
from api.report.html_parts import (
    document,
    escaped,
    name_html,
    nowrap,
    row,
    tag,
    td,
    th,
    timestamp,
)
from api.report.marks import halt_cause, halt_lines
from api.report.plots import number
from api.report.provenance import prior_line
from api.report.series import OperationSeries, Output, cycle_series, operation_series
from api.report.svg import render

#: A margin at the band edge smaller than this fraction of the limit is 0 (a binding limit).
BINDING_RTOL = 1e-6

_CSS = """
body { font: 14px/1.4 system-ui, -apple-system, "Segoe UI", Roboto, Arial, sans-serif;
       color: #222; margin: 2em auto; max-width: 84em; padding: 0 1em; }
h1 { font-size: 1.5em; } h2 { font-size: 1.25em; margin-top: 2em; border-bottom: 1px solid #ccc; }
/* tables fit their container (1280 px wide windows and up): cells wrap between words, never
   inside one; a number, a value with its unit and a name with hyphens stay on one line */
table { border-collapse: collapse; margin: 0.5em 0 1em; font-size: 0.85em; width: 100%; }
caption { text-align: left; font-weight: bold; padding: 0.2em 0; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.4em; vertical-align: top;
         overflow-wrap: normal; word-break: normal; hyphens: manual; }
th { background: #f3f3f3; text-align: left; }
td.num, #history td { text-align: right; font-variant-numeric: tabular-nums;
                      white-space: nowrap; }
#history td:nth-child(4), #history td:last-child, td.band { white-space: normal; }
.nw, th.name { white-space: nowrap; } .brk { white-space: normal; }
h1, dd { overflow-wrap: anywhere; }
#history td:nth-child(2), #history td:nth-child(3), #history td:nth-child(4),
#history td:last-child { text-align: left; }
tr.flagged td { color: #b00; }
.breach { color: #b00; font-weight: bold; } .above-band { color: #a40; font-weight: bold; }
.below-band { color: #a40; font-weight: bold; } .note { color: #555; font-style: italic; }
/* a reading too good to be true (implausible_low): a check for the operator, not a note */
span.check { color: #000; background: #fd0; border: 1px solid #a60; font-weight: bold;
             padding: 0 0.3em; } tr.check td { background: #fff6c2; }
section.halt { border: 2px solid #b00; padding: 0 1em; margin: 1em 0; }
section.halt h2 { color: #b00; border: none; }
/* narrower windows (800 px): a wide table scrolls sideways in its own box, never the page */
div.wide { overflow-x: auto; }
figure { margin: 1em 0; } figure svg { max-width: 100%; height: auto; display: block; }
figcaption { font-size: 0.9em; color: #555; }
dl { display: grid; grid-template-columns: max-content auto; gap: 0.1em 1em; }
dt { font-weight: bold; } dd { margin: 0; }
"""

_CAPTIONS = {
    "parameters": "Cutting parameters of each part (the setpoint it was made with) and of the "
    "next part (open markers); dotted: the bounds. After Ivester & Heigel Fig. 4a.",
    "outputs": "Constrained outputs: prediction ± band at the setpoint each part was made with "
    "(shaded) and at the next part's (open marker, blue bar), measured value ± its "
    "uncertainty (black error bars), limit (dashed), flagged RCB "
    "decisions (crosses), readings quarantined as implausibly low (yellow diamonds: check the "
    "sensor and the tool). After Ivester & Heigel Fig. 4b.",
    "bands": "Uncertainty band ΔY of each output. Line: the band in force at the setpoint each "
    "part was made with, the one the optimiser kept the limit with (open circle: the next "
    "part's). Triangles: the band that part's RCB update computed at the same setpoint. A "
    "green triangle below the line: the band shrank by part of the margin, and the next "
    "setpoint may be faster. A triangle above the line with a cross: a flagged reading; the "
    "band grew to cover it and the next setpoint backs off. A grey triangle above the line "
    "(RCB action hold): the band learned from the parts so far (strategies learn and bayes) "
    "is still wider than the one in force at that setpoint; nothing is relaxed, the setpoint "
    "keeps its band.",
    "productivity": "Material removal rate and machining time of the operation.",
}


def _num(value: float | None, **attributes: object) -> str:
    """A number cell, right-aligned, formatted as the plots' labels (:func:`plots.number`)."""
    return td(number(value), class_="num", **attributes)


# --------------------------------------------------------------------------------------------
# sections


def _status(plan: Mapping[str, Any]) -> str:
    if plan.get("status") == "halted":
        return "HALTED"
    # its reports are refused until a replan sets it anew (the plan page: the structure too)
    refused = plan.get("settings_refused") or plan.get("plan_refused")
    return f"REFUSED: {refused}" if refused else "running"


def _overview(record: Mapping[str, Any]) -> str:
    plan, totals, plotted = record["plan"], record["totals"], record["parts"]
    newest = record["history"]["versions"][-1]
    first, last = totals["first_cycle_time_min"], newest["cycle_time_min"]
    change = f" ({(last - first) / first:+.1%})" if first else ""
    count = totals["parts"]
    received = totals["last_received"]
    items = [
        ("Status", _status(plan)),
        ("Machine", plan["machine"]),
        ("RCB", f"{plan['strategy']}, α = {plan['alpha']:g}"),
        ("Models started from", prior_line(plan)),
        ("Plan created", timestamp(plan["created_at"])),
        ("Parts reported", f"{count}, last {timestamp(received)}" if count else 0),
        ("Setpoint version in force", newest["version"]),
        ("Cycle time", f"{number(first)} min at version 1 → {number(last)} min now{change}"),
        ("Flagged RCB decisions", f"{totals['flagged']} ({totals['breaches']} past a limit)"),
        ("Notes (information: below band, past limit, regime change …)", totals["notes"]),
    ]
    if plan.get("fleet_out"):  # its learned models make no new plan's prior, and why
        items.append(("Out of the fleet", plan["fleet_out"]))
    if len(plotted) < count:
        shown = f"the last {len(plotted)} parts, from {plotted[0]['serial']}" if plotted else "none"
        items.append(("Plotted", shown))
    names = _names(plan)
    listed = "".join(tag("dt", escaped(k)) + tag("dd", _unbroken(v, names)) for k, v in items)
    if totals.get("checks"):  # implausibly low readings: the operator checks sensor and tool
        text = escaped(f"{totals['checks']}: check the sensor and the tool")
        listed += tag("dt", escaped("CHECK SENSOR: implausibly low readings")) + tag(
            "dd", tag("span", text, class_="check")
        )
    return tag("dl", listed)


def _names(plan: Mapping[str, Any]) -> list[str]:
    """The plan's operations and the parts that let a prior go: names kept on one line."""
    lines = [p for ps in plan.get("provenance", {}).values() for p in ps]
    lines += plan.get("noise_provenance", [])
    serials = {p.get(k) for p in lines for k in ("widened_by_part", "let_go_by_part")}
    return [op["name"] for op in plan.get("operations", [])] + sorted(s for s in serials if s)


def _unbroken(value: object, names: Sequence[str]) -> str:
    """``value`` escaped, each of ``names`` in it as :func:`name_html` (``finish-contour``)."""
    text = escaped(value)
    if not names:
        return text
    words = "|".join(re.escape(escaped(n)) for n in sorted(names, key=len, reverse=True))
    return re.sub(
        f"(?<![\\w-])(?:{words})(?![\\w-])", lambda m: name_html(html.unescape(m[0])), text
    )


def _halt_section(plan: Mapping[str, Any]) -> str:
    """A halted plan: which limits cannot be met, and how to resume."""
    halt = plan.get("halt")
    if plan.get("status") != "halted" or not halt:
        return ""
    lines = "".join(tag("li", escaped(line)) for line in halt_lines(halt))
    cause = halt_cause(halt)
    text = (
        f"{cause[:1].upper()}{cause[1:]}: setpoints are refused (409 plan_halted) until "
        f"an engineer replans (rcb replan {plan['id']}, or POST .../replan)."
    )
    heading = tag("h2", escaped("HALTED"))
    return tag("section", heading + tag("p", escaped(text)) + tag("ul", lines), class_="halt")


def _margin(output: Output) -> float | None:
    """Margin to the limit at the band edge of the setpoint in force (DESIGN.md, "margin").

    Within the optimiser's binding tolerance (1 ppm of the limit) it is 0: a binding limit.
    """
    if output.limit is None:
        return None
    value, band = float(output.predicted[-1]), float(output.band[-1])
    margin = output.limit - (value + band) if output.sense == "max" else value - band - output.limit
    return 0.0 if abs(margin) <= BINDING_RTOL * output.limit else margin


def _setpoint_text(series: OperationSeries) -> str:
    """The parameters in force, each ``f = 0.32 mm/rev`` on one line (HTML)."""
    return ", ".join(
        nowrap(plots.parameter_value(name, float(values[-1])))
        for name, values in series.parameters.items()
    )


def _output_cells(
    series: OperationSeries, output: Output, latest: Mapping[tuple[str, str], Any]
) -> list[str]:
    value, band = float(output.predicted[-1]), float(output.band[-1])
    shown = math.isfinite(value) and math.isfinite(band) and value != 0
    relative = f" ({band / value:.1%})" if shown else ""
    d = latest.get((series.name, output.quantity))
    measured = escaped("–")
    if d is not None:
        flag = mark(d)
        serial = name_html(f"({d['serial']},")
        measured = f"{nowrap(number(d['margin']))} {serial} {escaped(d['action'])}" + (
            f", {flag})" if flag else ")"
        )
    word = plots.SENSE_WORDS[output.sense]  # "min" beside "Time [min]" would read as minutes
    predicted = f"{nowrap(f'{number(value)} ± {number(band)}')}{escaped(relative)}"
    return [
        td(plots.quantity_label(output.quantity)),
        tag("td", predicted, class_="num band") if shown else td("–", class_="num"),
        td(f"{number(output.limit)} ({word})" if output.limit is not None else "–", class_="num"),
        _num(_margin(output)),
        tag("td", measured),
    ]


def _setpoints_table(record: Mapping[str, Any], series: Sequence[OperationSeries]) -> str:
    history = record["history"]
    latest = {(d["operation"], d["quantity"]): d for d in record["last_decisions"]}
    head = row(
        th(h)
        for h in (
            "Operation",
            "Setpoint",
            "MRR [cm³/min]",
            "Time [min]",
            "Binding",
            "Output",
            "Predicted ± band",
            "Limit",
            "Margin at band edge",
            "Last measured margin (part, RCB action)",
        )
    )
    binding = {o["name"]: o["binding"] for o in history["versions"][-1]["operations"]}
    rows = []
    for s in series:
        span = max(len(s.outputs), 1)
        first = [
            tag("td", f"{name_html(s.name)} {name_html(f'({s.tool})')}", rowspan=span),
            tag("td", _setpoint_text(s), rowspan=span),
            _num(float(s.mrr_cm3_min[-1]), rowspan=span),
            _num(float(s.time_min[-1]), rowspan=span),
            td(", ".join(binding.get(s.name, [])), rowspan=span),
        ]
        outputs = [_output_cells(s, o, latest) for o in s.outputs] or [[td("–")] * 5]
        rows.append(row(first + outputs[0], data_operation=s.name))
        rows += [row(cells, data_operation=s.name) for cells in outputs[1:]]
    version = history["versions"][-1]["version"]
    caption = tag("caption", escaped(f"Setpoints in force (version {version})"))
    body = tag("thead", head) + tag("tbody", "".join(rows))
    return tag("table", caption + body, id="setpoints")


def _scrolls(table: str, label: str) -> str:
    """``table`` in a box of its own that scrolls sideways when the window is too narrow.

    Focusable and named, so a keyboard can scroll it too (WAI-ARIA: a region).
    """
    return tag("div", table, class_="wide", tabindex="0", role="region", aria_label=label)


def _figure(svg: str, caption: str, kind: str, operation: str | None) -> str:
    """An inline SVG (from :func:`api.report.svg.render`, already markup) with its caption."""
    return tag(
        "figure",
        svg + tag("figcaption", escaped(caption)),
        class_="plot",
        data_kind=kind,
        data_operation=operation,
    )


def _operation_section(index: int, series: OperationSeries) -> str:
    heading = tag("h2", escaped(f"Operation {series.name}: {series.tool}, {series.process}"))
    figures = [
        _figure(render(draw, series, f"op{index}-{kind}"), _CAPTIONS[kind], kind, series.name)
        for kind, draw in plots.OPERATION_PLOTS.items()
    ]
    return tag("section", heading + "".join(figures), data_operation=series.name)


# --------------------------------------------------------------------------------------------
# the page


def render_record(record: Mapping[str, Any]) -> str:
    """The HTML page of a plan's record.

    Parameters
    ----------
    record : Mapping
        :func:`api.services.read.record.report_record` (or
        :func:`api.report.full_record.full_record`):
        the plan, the parts to plot (oldest first), the setpoint versions they were made with
        and the newest ones, totals, summaries of older versions, last decisions and marks.

    Returns
    -------
    str
        A UTF-8 HTML5 document, self-contained (inline CSS and SVG, no script).
    """
    plan, history, plotted = record["plan"], record["history"], record["parts"]
    title = f"rcb report: plan {plan['name']} (id {plan['id']})"
    first = record["totals"]["parts"] - len(plotted) + 1
    series = [
        operation_series(plan, history, plotted, op["name"], first) for op in plan["operations"]
    ]
    cycle = render(plots.cycle_figure, cycle_series(history, plotted, first), "cycle")
    changes = tool_change_table(plotted)
    body = "".join(
        [
            tag("h1", escaped(title)),
            _overview(record),
            _halt_section(plan),
            tag("h2", escaped("Setpoints in force")),
            _scrolls(_setpoints_table(record, series), "Setpoints in force"),
            tag("h2", escaped("Tool changes")) + _scrolls(changes, "Tool changes")
            if changes
            else "",
            tag("h2", escaped("Setpoint history")),
            _figure(cycle, "Cycle time of the plan (all operations).", "cycle", None),
            _scrolls(history_table(record), "Setpoint versions"),
            *(_operation_section(i, s) for i, s in enumerate(series, start=1)),
            tag("footer", escaped("Written by rcb report. Plots after Ivester & Heigel, Fig. 4.")),
        ]
    )
    return document(title, _CSS, body)


def render_html_report(
    plan: Mapping[str, Any],
    history: Mapping[str, Any],
    parts: Sequence[Mapping[str, Any]],
    *,
    last: int | None = None,
) -> str:
    """The page of :func:`render_record` from complete lists (:func:`full_record`).

    Parameters
    ----------
    plan : Mapping
        :func:`api.services.read.plans.get_plan`.
    history : Mapping
        :func:`api.services.read.history.plan_history` of the same plan, every version.
    parts : Sequence of Mapping
        Every item of :func:`api.services.read.plan_parts.parts` of the same plan, oldest first.
    last : int, optional
        Plot and mark only the last ``last`` parts; the totals still count every part.
    """
    return render_record(full_record(plan, history, parts, last))
