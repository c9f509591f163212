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


def csv_bytes(frame: pd.DataFrame) -> bytes:
    """``frame`` as RFC 4180 CSV (UTF-8, CRLF) with :func:`csv_safe` cells.

    CRLF line ends make the writer quote a cell holding a bare carriage return, which a reader
    would otherwise take for the end of the row (the cell and the row after it lost).
    """
    text: str = csv_safe(frame).to_csv(index=False, lineterminator="\r\n")
    return text.encode("utf-8")


def tables(history: dict[str, Any], parts: list[dict[str, Any]]) -> dict[str, pd.DataFrame]:
    """The four tables from :func:`api.services.read.history.plan_history` and the plan's parts."""
    plan_id = history["plan_id"]
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
    setpoint_rows = []
    for v in history["versions"]:
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
            setpoint_rows.append(row)
    return {
        "parts": pd.DataFrame(part_rows),
        "measurements": pd.DataFrame(measurement_rows),
        "decisions": pd.DataFrame(decision_rows),
        "setpoints": pd.DataFrame(setpoint_rows),
    }
