"""The report's tables of what happened: setpoint versions (listed and summarised), tool changes.

Both take the record of :func:`api.services.read.record.report_record` (or
:func:`api.report.full_record.full_record`): the newest versions one by one, older ones as
the summaries the database computed, and the tool changes the shown parts called for.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from api.report.html_parts import (
    ONE_LINE_CHARS,
    escaped,
    name_html,
    nowrap,
    row,
    tag,
    td,
    th,
    timestamp_html,
)
from api.report.marks import decision_mark
from api.report.plots import number
from api.services.read.record import HISTORY_ROWS, TOOL_CHANGE


def _num(value: float | None, **attributes: object) -> str:
    return td(number(value), class_="num", **attributes)


def mark(d: Mapping[str, Any]) -> str:
    """A decision's flag or note as a ``span`` of its kind's class (empty if neither)."""
    label, kind = decision_mark(d)
    return tag("span", escaped(label), class_=kind) if label else ""


def listed_versions(history: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """The versions the table lists one by one: the newest :data:`HISTORY_ROWS`."""
    versions = history["versions"]
    cut = versions[-1]["version"] - HISTORY_ROWS
    return [v for v in versions if v["version"] > cut]


def history_table(record: Mapping[str, Any]) -> str:
    """Summaries of older versions, then each of the newest with its cause, MRR and marks."""
    history = record["history"]
    names = [o["name"] for o in history["versions"][-1]["operations"]]
    fixed = ("Version", "Cause", "Part", "Created", "Cycle time [min]")
    # two header rows: each cell says it heads the columns under it (WCAG technique H63; the
    # MRR cell all the operations' columns it spans), for a screen reader to name each cell
    head = row(
        [
            *(th(h, rowspan=2, scope="col") for h in fixed),
            th("MRR [cm³/min]", colspan=len(names), scope="col"),
            th("Flags and notes of the part", rowspan=2, scope="col"),
        ]
    ) + row(tag("th", name_html(n), class_="name", scope="col") for n in names)
    rows = [_summary_row(s, names) for s in record["summaries"]]
    marks = record["marks"]
    for v in listed_versions(history):
        mrr = {o["name"]: o["mrr_cm3_min"] for o in v["operations"]}
        marked = [d for d in marks.get(v["part_id"], []) if decision_mark(d)[0]]
        flagged = [d for d in marked if d["flagged"]]
        text = ", ".join(f"{_what(d)} {mark(d)}" for d in marked)
        kinds = sorted({decision_mark(d)[1] for d in flagged})
        checks = ["check"] if any(decision_mark(d)[1] == "check" for d in marked) else []
        # numbers right-aligned by the page's CSS (#history), not a class per cell: 200 rows
        cells = [
            td(v["version"]),
            td(v["cause"]),
            tag("td", name_html(v["serial"] or "–")),
            tag("td", timestamp_html(v["created_at"])),
            td(number(v["cycle_time_min"])),
            *(td(number(mrr.get(n))) for n in names),
            tag("td", text),
        ]
        classes = (["flagged", *kinds] if flagged else []) + checks
        rows.append(row(cells, class_=" ".join(classes) or None))
    caption = tag("caption", escaped("Setpoint versions: what caused each, and the MRR it gave"))
    body = tag("thead", head) + tag("tbody", "".join(rows))
    return tag("table", caption + body, id="history")


def _what(d: Mapping[str, Any]) -> str:
    """A decision's operation and quantity, on one line unless the operation's name is long."""
    operation, quantity = d["operation"], d["quantity"]
    if len(operation) <= ONE_LINE_CHARS:
        return nowrap(f"{operation} {quantity}")
    return f"{name_html(operation)} {nowrap(quantity)}"


def _summary_row(summary: Mapping[str, Any], names: Sequence[str]) -> str:
    """One row for a group of older versions: their range, first and last cycle time and MRR."""
    first, last = summary["first"], summary["last"]
    mrr = {o["name"]: o["mrr_cm3_min"] for o in last["operations"]}
    cells = [
        td(f"{first['version']}–{last['version']}", class_="num"),
        td(f"{summary['versions']} versions"),
        tag("td", f"{name_html(first['serial'] or '–')} … {name_html(last['serial'] or '–')}"),
        tag("td", f"{timestamp_html(first['created_at'])} … {timestamp_html(last['created_at'])}"),
        td(f"{number(first['cycle_time_min'])} → {number(last['cycle_time_min'])}", class_="num"),
        *(_num(mrr.get(n)) for n in names),
        tag("td", f"summarised ({nowrap('rcb history --json')} for every version)"),
    ]
    return row(cells, class_="summary")


def tool_changes(parts: Sequence[Mapping[str, Any]]) -> list[tuple[str, str, dict[str, Any]]]:
    """Feed overrides that called for a tool change, and each operation's last one.

    As (serial, operation, reading), in the order reported.
    """
    found = [
        (str(p["serial"]), str(op["name"]), op["measurements"][TOOL_CHANGE])
        for p in parts
        for op in p["operations"]
        if TOOL_CHANGE in op.get("measurements", {})
    ]
    last = {operation: i for i, (_, operation, _) in enumerate(found)}
    return [
        item
        for i, item in enumerate(found)
        if (item[2].get("raw") or {}).get("tool_change_due") or last[item[1]] == i
    ]


def tool_change_table(parts: Sequence[Mapping[str, Any]]) -> str:
    """The feed overrides the shown parts reported, and whether each called for a tool change.

    Empty if none did (plans without constant load).
    """
    found = tool_changes(parts)
    if not found:
        return ""
    head = row(
        th(h)
        for h in (
            "Part",
            "Operation",
            "Feed override [%]",
            "Commanded feed [mm/min]",
            "Lower limit [mm/min]",
            "Tool change",
        )
    )
    rows = []
    for serial, operation, reading in found:
        raw = reading.get("raw") or {}
        due = bool(raw.get("tool_change_due"))
        verdict = ("DUE: " if due else "not due: ") + str(raw.get("reason", ""))
        cells = [
            tag("td", name_html(serial)),
            tag("td", name_html(operation)),
            _num(reading["value"]),
            _num(raw.get("commanded_feed_rate_mm_min")),
            _num(raw.get("feed_rate_lower_mm_min")),
            tag("td", tag("span", escaped(verdict), class_="breach" if due else None)),
        ]
        rows.append(row(cells, class_="due" if due else None, data_operation=operation))
    caption = tag("caption", escaped("Feed overrides reported and the tool changes they call for"))
    body = tag("thead", head) + tag("tbody", "".join(rows))
    return tag("table", caption + body, id="tool-changes")
