"""``rcb parts`` output a page at a time: a rich table per page, or JSON streamed part by part."""

from __future__ import annotations

import json
import sys
from collections.abc import Callable, Iterable
from datetime import datetime
from typing import Any

from rich.table import Table

from api.cli.tables import new_table


def stream_json(plan_id: int, pages: Iterable[list[dict[str, Any]]]) -> None:
    """Print ``{"plan_id": .., "parts": [..]}`` on stdout, a part per line, written as read."""
    out = sys.stdout
    out.write(f'{{"plan_id": {plan_id}, "parts": [')
    sep = "\n"
    for page in pages:
        for item in page:
            out.write(sep + json.dumps(item, default=_iso))
            sep = ",\n"
    out.write("\n]}\n")
    out.flush()


def _iso(value: object) -> str:
    if isinstance(value, datetime):
        return value.isoformat()
    raise TypeError(type(value).__name__)


def parts_table(
    title: str,
    items: list[dict[str, Any]],
    fmt: Callable[[float | None], str],
    mark: Callable[[dict[str, Any]], str],
) -> Table:
    """One page of parts as a table: a row per measurement, the decision on it.

    ``fmt`` formats a number, ``mark`` a decision's flag (:mod:`api.cli.review`).
    """
    table = new_table(title=title)
    for column in ("part", "operation", "quantity", "measured\n± u"):
        table.add_column(column, justify="right" if column.startswith("measured") else "left")
    for column in ("margin", "action", "flag / note"):
        table.add_column(column, justify="right" if column == "margin" else "left")
    for part in items:
        decided = {(d["operation"], d["quantity"]): d for d in part["updates"]}
        first = True
        for op in part["operations"]:
            for q, m in op["measurements"].items():
                d = decided.get((op["name"], q), {})
                received = part["received_at"].strftime("%m-%d %H:%M:%S")
                table.add_row(
                    f"{part['serial']}\nver {part['setpoint_version']}\n{received}"
                    if first
                    else "",
                    op["name"],
                    q + (" (raw)" if m.get("raw") else ""),
                    f"{fmt(m['value'])}\n±{fmt(m['uncertainty'])}",
                    fmt(d.get("margin")),
                    d.get("action", "-"),
                    mark(d),
                )
                first = False
    return table
