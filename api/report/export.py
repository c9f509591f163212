"""A plan's record as tidy tables (pandas): one row per observation, units in column names.

- ``parts``: one row per part (serial, the setpoint version it was made with, when received).
- ``measurements``: one row per part, operation and measured quantity; ``value`` and
  ``uncertainty`` are in the unit the quantity's name carries (``force_N``: N), and a
  converted spindle reading keeps ``raw_quantity`` and ``raw_value``.
- ``decisions``: one row per RCB decision (band before and after, margin; the quantity's unit).
- ``setpoints``: one row per setpoint version and operation: parameters (``depth_mm`` ...),
  ``mrr_cm3_min``, ``time_min``, binding limits, and each prediction with its band as
  ``<quantity>`` and ``<quantity>_band`` columns.

A CSV file is opened by spreadsheets, which run a cell that starts with ``=``, ``+``, ``-``,
``@``, a tab or a carriage return as a formula (CSV injection): :func:`csv_safe` prefixes such a
text cell with a single quote (OWASP's rule). Numbers stay numbers (``-0.5`` is a number, not a
formula); a parquet file holds typed columns no spreadsheet evaluates and is written as stored.
"""

from __future__ import annotations

from typing import Any

import pandas as pd

#: What a spreadsheet takes as the start of a formula (OWASP, CSV injection).
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")


def neutralised(cell: object) -> object:
    """``cell`` with a single quote before it when it is text a spreadsheet would run."""
    if isinstance(cell, str) and cell.startswith(FORMULA_STARTS):
        return "'" + cell
    return cell


def csv_safe(frame: pd.DataFrame) -> pd.DataFrame:
    """A copy of ``frame`` whose text cells no spreadsheet runs as a formula; numbers untouched."""
    safe = frame.copy()
    for column in safe.columns:
        if not pd.api.types.is_numeric_dtype(safe[column]):  # text: object or str dtype
            safe[column] = safe[column].map(neutralised)
    return safe


def csv_bytes(frame: pd.DataFrame, header: bool = True) -> bytes:
    """``frame`` as RFC 4180 CSV (UTF-8, CRLF) with :func:`csv_safe` cells; ``header``: its names.

    CRLF line ends make the writer quote a cell holding a bare carriage return, which a reader
    would otherwise take for the end of the row (the cell and the row after it lost).
    """
    text: str = csv_safe(frame).to_csv(index=False, header=header, lineterminator="\r\n")
    return text.encode("utf-8")


#: The columns of the tables whose columns every plan shares, with their types (pyarrow's
#: names): a page whose cells are all empty is written with the same types as the others.
COLUMNS: dict[str, dict[str, str]] = {
    "parts": {
        "plan_id": "int64",
        "part_id": "int64",
        "serial": "string",
        "setpoint_version": "int64",
        "received_at": "timestamp",
    },
    "measurements": {
        "part_id": "int64",
        "serial": "string",
        "operation": "string",
        "quantity": "string",
        "value": "float64",
        "uncertainty": "float64",
        "raw_quantity": "string",
        "raw_value": "float64",
    },
    "decisions": {
        "part_id": "int64",
        "serial": "string",
        "operation": "string",
        "quantity": "string",
        "action": "string",
        "margin": "float64",
        "band_before": "float64",
        "band_after": "float64",
        "predicted": "float64",
        "measured": "float64",
        "flagged": "bool",
        "flag": "string",
        "note": "string",
        "reason": "string",
    },
}
#: The setpoints table's columns before its parameters and predictions (each a float64).
SETPOINT_HEAD: dict[str, str] = {
    "version": "int64",
    "cause": "string",
    "serial": "string",
    "created_at": "timestamp",
    "operation": "string",
    "tool": "string",
}
#: The setpoints table's text column after the numbers; every other column is a float64.
SETPOINT_TEXT = ("binding",)


def part_frames(plan_id: int, parts: list[dict[str, Any]]) -> dict[str, pd.DataFrame]:
    """``parts``, ``measurements`` and ``decisions`` of a page of parts (:data:`COLUMNS`)."""
    part_rows = [
        {
            "plan_id": plan_id,
            "part_id": p["part_id"],
            "serial": p["serial"],
            "setpoint_version": p["setpoint_version"],
            "received_at": p["received_at"],
        }
        for p in parts
    ]
    measurement_rows = [
        {
            "part_id": p["part_id"],
            "serial": p["serial"],
            "operation": op["name"],
            "quantity": q,
            "value": m["value"],
            "uncertainty": m["uncertainty"],
            "raw_quantity": (m.get("raw") or {}).get("quantity"),
            "raw_value": (m.get("raw") or {}).get("value"),
        }
        for p in parts
        for op in p["operations"]
        for q, m in op["measurements"].items()
    ]
    decision_rows = [
        {"part_id": p["part_id"], "serial": p["serial"], **d} for p in parts for d in p["updates"]
    ]
    rows = {"parts": part_rows, "measurements": measurement_rows, "decisions": decision_rows}
    return {name: pd.DataFrame(rows[name], columns=list(COLUMNS[name])) for name in rows}


def setpoint_frame(versions: list[dict[str, Any]]) -> pd.DataFrame:
    """A row per setpoint version and operation of a page of the plan's history.

    The columns: :data:`SETPOINT_HEAD`, the operations' parameters (``depth_mm`` ...),
    ``mrr_cm3_min``, ``time_min``, ``binding``, and each prediction with its band.
    """
    rows = []
    for v in versions:
        for op in v["operations"]:
            row: dict[str, Any] = {
                "version": v["version"],
                "cause": v["cause"],
                "serial": v["serial"],
                "created_at": v["created_at"],
                "operation": op["name"],
                "tool": op["tool"],
                **op["setpoint"],
                "mrr_cm3_min": op["mrr_cm3_min"],
                "time_min": op["time_min"],
                "binding": " ".join(op["binding"]),
            }
            for q, p in op["predicted"].items():
                row[q], row[f"{q}_band"] = p["value"], p["band"]
            rows.append(row)
    return pd.DataFrame(rows)


def column_types(name: str, columns: list[str]) -> dict[str, str]:
    """Each column's type in table ``name``: :data:`COLUMNS`, or a setpoint's (float64)."""
    if name in COLUMNS:
        return COLUMNS[name]
    text = {**SETPOINT_HEAD, **dict.fromkeys(SETPOINT_TEXT, "string")}
    return {c: text.get(c, "float64") for c in columns}
