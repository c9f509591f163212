"""``rcb demo``'s output: its JSON document and its tables."""

from __future__ import annotations

import shlex
import textwrap
from collections.abc import Mapping
from typing import Any

from rich.table import Table

from api.cli.tables import PARAMETER_HEADINGS, fmt, new_table
from api.services.to_json import predictions_json
from models.powerlaw import Prediction
from supervisor.inputs.part_report import Measurement
from supervisor.virtual.demo import DemoResult, Row


def _row_json(row: Row) -> dict[str, Any]:
    return {
        "setpoint": dict(row.setpoint),
        "mrr_cm3_min": row.mrr_cm3_min,
        "time_min": row.time_min,
        "predicted": predictions_json(row.predicted),
        "measured": {
            q: {"value": m.value, "uncertainty": m.uncertainty} for q, m in row.measured.items()
        },
    }


def demo_json(result: DemoResult, strategy: str, seed: int) -> dict[str, Any]:
    """``rcb demo --json``: rows C, R, final per operation, cycle times, violations."""
    return {
        "strategy": strategy,
        "seed": seed,
        "parts": result.parts,
        "violations": result.violations,
        "flagged": result.flagged,
        "setpoint_version": result.final_state.version,
        "operations": [
            {
                "name": op.name,
                "catalog": None if op.catalog is None else _row_json(op.catalog),
                "robust": _row_json(op.robust),
                "final": _row_json(op.final),
            }
            for op in result.operations
        ],
        "cycle_time_min": dict(result.cycle_time_min),
        "gain_captured": gain_captured(result.cycle_time_min),
    }


def gain_captured(cycle: Mapping[str, float | None]) -> float | None:
    """``(robust − final) / (robust − oracle)``: the share of the oracle's gain RCB earned."""
    robust, final, oracle = cycle.get("robust"), cycle.get("final"), cycle.get("oracle")
    if robust is None or final is None or oracle is None or robust - oracle <= 0:
        return None
    return (robust - final) / (robust - oracle)


def _pm(p: Prediction | None) -> str:
    return "" if p is None else f"{fmt(p.value)}\n±{p.band:.3g}"


def _meas(m: Measurement | None) -> str:
    return "" if m is None else f"{fmt(m.value)}\n±{m.uncertainty:.3g}"


def demo_tables(result: DemoResult) -> list[Table | str]:
    """What the rows are, one Table-5-like table per operation, the cycle times, a summary.

    The summary is not the cycle table's caption: a caption wraps at its table's width (39
    cells), which split a count from its noun (``0`` at a line's end, ``true-limit
    violations`` on the next); each line here fits 60 columns whole.
    """
    tables: list[Table | str] = [legend(result), ""]
    for op in result.operations:
        table = new_table(title=f"{op.name}", title_justify="left")
        names = tuple(op.robust.setpoint)
        columns: tuple[str, ...] = ("", *(PARAMETER_HEADINGS.get(p, p) for p in names))
        columns += ("MRR\ncm³/min", "F N\nmodel", "Ra µm\nmodel", "F N\nmeas.", "Ra µm\nmeas.")
        for column in columns:
            table.add_column(column, justify="right")
        labelled = (("C", op.catalog), ("R", op.robust), ("final", op.final))
        for label, row in labelled:
            if row is None:
                continue
            s = row.setpoint
            table.add_row(
                label,
                *(fmt(s[p]) if p in s else "" for p in names),
                fmt(row.mrr_cm3_min),
                _pm(row.predicted.get("force_N")),
                _pm(row.predicted.get("roughness_um")),
                _meas(row.measured.get("force_N")),
                _meas(row.measured.get("roughness_um")),
            )
        tables.append(table)
    cycle = result.cycle_time_min
    summary = new_table(title="cycle time", title_justify="left")
    for column in ("", "min", "vs catalogue", "vs robust"):
        summary.add_column(column, justify="right")
    for label in ("catalog", "robust", "final", "oracle"):
        value = cycle.get(label)
        if value is None:
            continue
        summary.add_row(
            label, fmt(value), _change(value, cycle["catalog"]), _change(value, cycle["robust"])
        )
    captured = gain_captured(cycle)
    share = "" if captured is None else f"{100 * captured:.0f} % of the oracle's gain, "
    tables.append(summary)
    tables.append(f"{result.parts} parts, {share}setpoint version {result.final_state.version}")
    tables.append(
        f"{result.violations} true-limit violations, {result.flagged} flagged measurements"
    )
    return tables


def legend(result: DemoResult) -> str:
    """What the tables' rows and columns are, filled to 80 columns.

    Before it, a first run showed rows ``C`` and ``R`` unexplained.
    """
    plan, parts = result.final_state.plan, result.parts
    return textwrap.fill(
        f"{plan.name} on a virtual {plan.machine.name}, {parts} parts. Per operation, C: the "
        f"catalogue's parameters, R: the robust start, final: the setpoints after part "
        f"{parts}; model: the prediction ± its band, meas.: the reading at those "
        f"setpoints ± its uncertainty (the layout of Ivester & Heigel's Table 5).",
        width=80,
        break_on_hyphens=False,
        break_long_words=False,
    )


def _change(value: float, reference: float | None) -> str:
    return "" if not reference else f"{100 * (value / reference - 1):+.1f} %"


def stored_line(plan_id: int, name: str, url: str) -> str:
    """Where the demonstration is stored, then each command that shows it on a line of its own.

    The sentence is filled to 80 columns; a command is never broken (one longer than 80
    columns stays one line), so it can be copied whole.
    """
    db = f"--db {url}"
    told = textwrap.fill(
        f"rcb: stored in {url} as plan {plan_id} ({name}); to see it:",
        width=80,
        subsequent_indent="  ",
        break_on_hyphens=False,
        break_long_words=False,
    )
    # a page named after its plan: a second run's (name-2) does not overwrite the first's
    page = shlex.quote(f"{name}.html")
    commands = (f"rcb history {plan_id} {db}", f"rcb report {plan_id} {db} --out {page}")
    return "\n".join([told, *(f"  {command}" for command in commands)])
