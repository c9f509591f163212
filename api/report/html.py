"""A plan's production record as one self-contained HTML page an engineer can mail.

:func:`render_html_report` takes the JSON dicts of :mod:`api.services.queries` (``get_plan``,
``plan_history`` and all items of ``parts``) and returns the page: the setpoints in force with
their bands and margins, every setpoint version with its cause and MRR, the cycle time, and per
operation the plots of :mod:`api.report.plots` (after Ivester & Heigel, Fig. 4).

Self-contained: CSS and SVG are inline; nothing is loaded from elsewhere, no script runs. The
only URIs in the page are the XML namespace names the inline SVGs declare
(``http://www.w3.org/2000/svg``, ``http://www.w3.org/1999/xlink``), which identify and fetch
nothing. Every piece of text from the database is escaped (:func:`html.escape`); the page is
also well-formed XML, so XML tools can read it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from api.report import plots
from api.report.html_parts import document, escaped, row, tag, td, th, timestamp
from api.report.marks import decision_mark, halt_lines
from api.report.plots import number
from api.report.series import OperationSeries, Output, cycle_series, operation_series
from api.report.svg import render

#: A margin at the band edge smaller than this fraction of the limit is 0 (a binding limit).
BINDING_RTOL = 1e-6
#: Setpoint versions the history table lists one by one (the newest); older ones are summarised.
HISTORY_ROWS = 200
#: Older setpoint versions per summary row.
SUMMARY_GROUP = 100

_CSS = """
body { font: 14px/1.4 system-ui, -apple-system, "Segoe UI", Roboto, Arial, sans-serif;
       color: #222; margin: 2em auto; max-width: 60em; padding: 0 1em; }
h1 { font-size: 1.5em; } h2 { font-size: 1.25em; margin-top: 2em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: 0.5em 0 1em; font-size: 0.9em;
        display: block; max-width: 100%; overflow-x: auto; }  /* wide tables scroll */
th, td { border: 1px solid #ccc; padding: 0.2em 0.5em; vertical-align: top; }
th { background: #f3f3f3; text-align: left; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
tr.flagged td { color: #b00; }
.breach { color: #b00; font-weight: bold; } .above-band { color: #c50; font-weight: bold; }
.below-band { color: #c50; font-weight: bold; } .note { color: #555; font-style: italic; }
section.halt { border: 2px solid #b00; padding: 0 1em; margin: 1em 0; }
section.halt h2 { color: #b00; border: none; }
figure { margin: 1em 0; } figure svg { max-width: 100%; height: auto; }
figcaption { font-size: 0.9em; color: #555; }
dl { display: grid; grid-template-columns: max-content auto; gap: 0.1em 1em; }
dt { font-weight: bold; } dd { margin: 0; }
"""

_CAPTIONS = {
    "parameters": "Cutting parameters of each part (the setpoint it was made with) and of the "
    "next part (open markers); dotted: the bounds. After Ivester & Heigel Fig. 4a.",
    "outputs": "Constrained outputs: prediction ± band at the setpoint each part was made with "
    "(shaded), measured value ± its uncertainty (error bars), limit (dashed), flagged RCB "
    "decisions (crosses). After Ivester & Heigel Fig. 4b.",
    "bands": "Uncertainty band ΔY of each output at the setpoint a part was made with, and "
    "what that part's RCB update left at the same setpoint.",
    "productivity": "Material removal rate and machining time of the operation.",
}


def _num(value: float | None, **attributes: object) -> str:
    """A number cell, right-aligned, formatted as the plots' labels (:func:`plots.number`)."""
    return td(number(value), class_="num", **attributes)


# --------------------------------------------------------------------------------------------
# sections


def _overview(
    plan: Mapping[str, Any],
    history: Mapping[str, Any],
    parts: Sequence[Mapping[str, Any]],
    plotted: Sequence[Mapping[str, Any]],
) -> str:
    versions = history["versions"]
    first, last = versions[0]["cycle_time_min"], versions[-1]["cycle_time_min"]
    change = f" ({(last - first) / first:+.1%})" if first else ""
    flagged = sum(bool(d["flagged"]) for p in parts for d in p["updates"])
    breaches = sum(d.get("flag") == "breach" for p in parts for d in p["updates"])
    notes = sum(bool(d.get("note")) for p in parts for d in p["updates"])
    items = [
        ("Status", "HALTED" if plan.get("status") == "halted" else "running"),
        ("Machine", plan["machine"]),
        ("RCB", f"{plan['strategy']}, α = {plan['alpha']:g}"),
        ("Plan created", timestamp(plan["created_at"])),
        (
            "Parts reported",
            f"{len(parts)}, last {timestamp(parts[-1]['received_at'])}" if parts else 0,
        ),
        ("Setpoint version in force", versions[-1]["version"]),
        ("Cycle time", f"{number(first)} min at version 1 → {number(last)} min now{change}"),
        ("Flagged RCB decisions", f"{flagged} ({breaches} past a limit)"),
        ("Below-band notes (model pessimistic)", notes),
    ]
    if len(plotted) < len(parts):
        shown = f"the last {len(plotted)} parts, from {plotted[0]['serial']}" if plotted else "none"
        items.append(("Plotted", shown))
    return tag("dl", "".join(tag("dt", escaped(k)) + tag("dd", escaped(v)) for k, v in items))


def _halt_section(plan: Mapping[str, Any]) -> str:
    """A halted plan: which limits cannot be met, and how to resume."""
    halt = plan.get("halt")
    if plan.get("status") != "halted" or not halt:
        return ""
    lines = "".join(tag("li", escaped(line)) for line in halt_lines(halt))
    text = (
        "No setpoint meets the bands in force: setpoints are refused (409 plan_halted) until "
        f"an engineer replans (rcb replan {plan['id']}, or POST .../replan)."
    )
    heading = tag("h2", escaped("HALTED"))
    return tag("section", heading + tag("p", escaped(text)) + tag("ul", lines), class_="halt")


def _mark(d: Mapping[str, Any]) -> str:
    """A decision's flag or note as a ``span`` of its kind's class (empty if neither)."""
    label, kind = decision_mark(d)
    return tag("span", escaped(label), class_=kind) if label else ""


def _margin(output: Output) -> float | None:
    """Margin to the limit at the band edge of the setpoint in force (DESIGN.md, "margin").

    Within the optimiser's binding tolerance (1 ppm of the limit) it is 0: a binding limit.
    """
    if output.limit is None:
        return None
    value, band = float(output.predicted[-1]), float(output.band[-1])
    margin = output.limit - (value + band) if output.sense == "max" else value - band - output.limit
    return 0.0 if abs(margin) <= BINDING_RTOL * output.limit else margin


def _last_decision(
    parts: Sequence[Mapping[str, Any]], operation: str, quantity: str
) -> tuple[str, Mapping[str, Any]] | None:
    for part in reversed(parts):
        for d in part["updates"]:
            if d["operation"] == operation and d["quantity"] == quantity:
                return str(part["serial"]), d
    return None


def _setpoint_text(series: OperationSeries) -> str:
    return ", ".join(
        plots.parameter_value(name, float(values[-1])) for name, values in series.parameters.items()
    )


def _output_cells(series: OperationSeries, output: Output, parts: Sequence[Any]) -> list[str]:
    value, band = float(output.predicted[-1]), float(output.band[-1])
    relative = f" ({band / value:.1%})" if value else ""
    last = _last_decision(parts, series.name, output.quantity)
    measured = escaped("–")
    if last is not None:
        serial, d = last
        mark = _mark(d)
        measured = escaped(f"{number(d['margin'])} ({serial}, {d['action']}") + (
            f", {mark})" if mark else ")"
        )
    word = "max" if output.sense == "max" else "min"
    return [
        td(plots.quantity_label(output.quantity)),
        td(f"{number(value)} ± {number(band)}{relative}", class_="num"),
        td(f"{number(output.limit)} ({word})" if output.limit is not None else "–", class_="num"),
        _num(_margin(output)),
        tag("td", measured, class_="num"),
    ]


def _setpoints_table(
    history: Mapping[str, Any],
    series: Sequence[OperationSeries],
    parts: Sequence[Mapping[str, Any]],
) -> str:
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
            td(f"{s.name} ({s.tool})", rowspan=span),
            td(_setpoint_text(s), rowspan=span),
            _num(float(s.mrr_cm3_min[-1]), rowspan=span),
            _num(float(s.time_min[-1]), rowspan=span),
            td(", ".join(binding.get(s.name, [])), rowspan=span),
        ]
        outputs = [_output_cells(s, o, parts) for o in s.outputs] or [[td("–")] * 5]
        rows.append(row(first + outputs[0], data_operation=s.name))
        rows += [row(cells, data_operation=s.name) for cells in outputs[1:]]
    version = history["versions"][-1]["version"]
    caption = tag("caption", escaped(f"Setpoints in force (version {version})"))
    body = tag("thead", head) + tag("tbody", "".join(rows))
    return tag("table", caption + body, id="setpoints")


def _history_table(history: Mapping[str, Any], parts: Sequence[Mapping[str, Any]]) -> str:
    names = [o["name"] for o in history["versions"][0]["operations"]]
    fixed = ("Version", "Cause", "Part", "Created", "Cycle time [min]")
    head = row(
        [
            *(th(h, rowspan=2) for h in fixed),
            th("MRR [cm³/min]", colspan=len(names)),
            th("Flags and notes of the part", rowspan=2),
        ]
    ) + row(th(n) for n in names)
    updates = {p["part_id"]: p["updates"] for p in parts}
    older, recent = _split_history(history["versions"])
    rows = [_summary_row(group, names) for group in older]
    for v in recent:
        mrr = {o["name"]: o["mrr_cm3_min"] for o in v["operations"]}
        marked = [d for d in updates.get(v["part_id"], []) if decision_mark(d)[0]]
        flagged = [d for d in marked if d["flagged"]]
        marks = ", ".join(escaped(f"{d['operation']} {d['quantity']} ") + _mark(d) for d in marked)
        kinds = sorted({decision_mark(d)[1] for d in flagged})
        cells = [
            td(v["version"], class_="num"),
            td(v["cause"]),
            td(v["serial"] or "–"),
            td(timestamp(v["created_at"])),
            _num(v["cycle_time_min"]),
            *(_num(mrr.get(n)) for n in names),
            tag("td", marks),
        ]
        rows.append(row(cells, class_=" ".join(["flagged", *kinds]) if flagged else None))
    caption = tag("caption", escaped("Setpoint versions: what caused each, and the MRR it gave"))
    body = tag("thead", head) + tag("tbody", "".join(rows))
    return tag("table", caption + body, id="history")


def _split_history(
    versions: Sequence[Mapping[str, Any]],
) -> tuple[list[Sequence[Mapping[str, Any]]], Sequence[Mapping[str, Any]]]:
    """Older versions in groups of :data:`SUMMARY_GROUP`, and the newest :data:`HISTORY_ROWS`.

    The history table then stays small whatever the plan's age.
    """
    cut = max(0, len(versions) - HISTORY_ROWS)
    older = [versions[i : min(i + SUMMARY_GROUP, cut)] for i in range(0, cut, SUMMARY_GROUP)]
    return older, versions[cut:]


def _summary_row(group: Sequence[Mapping[str, Any]], names: Sequence[str]) -> str:
    """One row for a group of older versions: their range, first and last cycle time and MRR."""
    first, last = group[0], group[-1]
    mrr = {o["name"]: o["mrr_cm3_min"] for o in last["operations"]}
    cells = [
        td(f"{first['version']}–{last['version']}", class_="num"),
        td(f"{len(group)} versions"),
        td(f"{first['serial'] or '–'} … {last['serial'] or '–'}"),
        td(f"{timestamp(first['created_at'])} … {timestamp(last['created_at'])}"),
        td(f"{number(first['cycle_time_min'])} → {number(last['cycle_time_min'])}", class_="num"),
        *(_num(mrr.get(n)) for n in names),
        td("summarised (rcb history --json for every version)"),
    ]
    return row(cells, class_="summary")


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


def render_html_report(
    plan: Mapping[str, Any],
    history: Mapping[str, Any],
    parts: Sequence[Mapping[str, Any]],
    *,
    last: int | None = None,
) -> str:
    """The HTML page of a plan's record.

    Parameters
    ----------
    plan : Mapping
        :func:`api.services.queries.get_plan`.
    history : Mapping
        :func:`api.services.queries.plan_history` of the same plan.
    parts : Sequence of Mapping
        Every item of :func:`api.services.queries.parts` of the same plan, oldest first.
    last : int, optional
        Plot only the last ``last`` parts (the page grows by about 6 kB per part plotted);
        the tables still cover every part and setpoint version.

    Returns
    -------
    str
        A UTF-8 HTML5 document, self-contained (inline CSS and SVG, no script).
    """
    if last is not None and last < 1:
        raise ValueError(f"last = {last!r}: must be at least 1")
    title = f"rcb report: plan {plan['name']} (id {plan['id']})"
    plotted = parts[-last:] if last is not None else parts
    first = len(parts) - len(plotted) + 1
    series = [
        operation_series(plan, history, plotted, op["name"], first) for op in plan["operations"]
    ]
    cycle = render(plots.cycle_figure, cycle_series(history, plotted, first), "cycle")
    body = "".join(
        [
            tag("h1", escaped(title)),
            _overview(plan, history, parts, plotted),
            _halt_section(plan),
            tag("h2", escaped("Setpoints in force")),
            _setpoints_table(history, series, parts),
            tag("h2", escaped("Setpoint history")),
            _figure(cycle, "Cycle time of the plan (all operations).", "cycle", None),
            _history_table(history, parts),
            *(_operation_section(i, s) for i, s in enumerate(series, start=1)),
            tag("footer", escaped("Written by rcb report. Plots after Ivester & Heigel, Fig. 4.")),
        ]
    )
    return document(title, _CSS, body)
