"""A report's record computed in Python from every part and every setpoint version.

:func:`api.services.read.record.report_record` reads a bounded record with SQL aggregates; this
computes the same record from the complete lists (``get_plan``, a whole ``plan_history`` and
every ``parts`` item, oldest first), for callers that already hold them and for the tests that
check the SQL against it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from api.services.read.record import HISTORY_ROWS, group_size


def full_record(
    plan: Mapping[str, Any],
    history: Mapping[str, Any],
    parts: Sequence[Mapping[str, Any]],
    last: int | None = None,
) -> dict[str, Any]:
    """The record :func:`api.services.read.record.report_record` reads, from complete lists.

    ``last``: the parts kept (the last ``last``; all if None).
    """
    if last is not None and last < 1:
        raise ValueError(f"last = {last!r}: must be at least 1")
    versions = list(history["versions"])
    cut = max(0, versions[-1]["version"] - HISTORY_ROWS)
    older = [v for v in versions if v["version"] <= cut]
    size = group_size(cut)
    groups = [older[i : i + size] for i in range(0, len(older), size)]
    listed = {v["part_id"] for v in versions if v["version"] > cut and v["part_id"] is not None}
    decisions = [(p, d) for p in parts for d in p["updates"]]
    latest: dict[tuple[str, str], dict[str, Any]] = {}
    for p, d in decisions:
        latest[(d["operation"], d["quantity"])] = {**d, "serial": p["serial"]}
    return {
        "plan": plan,
        "history": history,
        "parts": list(parts[-last:] if last is not None else parts),
        "totals": {
            "parts": len(parts),
            "last_received": parts[-1]["received_at"] if parts else None,
            "flagged": sum(bool(d["flagged"]) for _, d in decisions),
            "breaches": sum(d.get("flag") == "breach" for _, d in decisions),
            "notes": sum(bool(d.get("note")) for _, d in decisions),
            "checks": sum(d.get("note") == "implausible_low" for _, d in decisions),
            "first_cycle_time_min": versions[0]["cycle_time_min"],
        },
        "summaries": [{"first": g[0], "last": g[-1], "versions": len(g)} for g in groups],
        "last_decisions": list(latest.values()),
        "marks": {
            p["part_id"]: [d for d in p["updates"] if d["flagged"] or d.get("note")]
            for p in parts
            if p["part_id"] in listed and any(d["flagged"] or d.get("note") for d in p["updates"])
        },
    }
