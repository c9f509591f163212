"""What typed tables cost an answer (issue 30, point 6): validate and write one operation.

The REST answers validate every operation of a setpoint page or a history page and write it
as JSON (``api.rest.rendering``). Here one history operation, as the service builds it, goes
through the schema as it is now (``setpoint`` and ``predicted`` typed tables of registered
names, ``api.rest.schemas.quantities``) and through the same schema with free maps (the
reference, as before), in one run, alternating. Prints microseconds per operation and the
ratio. Run::

    .venv/bin/python benchmarks/openapi_tables.py --rounds 5 --n 20000
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Any

from pydantic import TypeAdapter

from api.rest.schemas.common import Band, Out
from api.rest.schemas.review import HistoryOperation, ModelInForce
from models.quantities import QUANTITIES


class FreeMapsOperation(Out):
    """The reference: ``HistoryOperation`` with free maps, as before the typed tables."""

    name: str
    tool: str
    setpoint: dict[str, float]
    predicted: dict[str, Band]
    mrr_cm3_min: float
    time_min: float
    binding: list[str]
    models: dict[str, ModelInForce]


ITEM: dict[str, Any] = {
    "name": "rough-od",
    "tool": "CNMG432RN",
    "setpoint": {"depth_mm": 2.943, "feed_mm_rev": 0.3248, "speed_m_min": 200.0},
    "predicted": {
        q: {"value": 1867.97, "band": 131.55}
        for q in QUANTITIES
        if q != "spindle_current_A"  # the demo's rough OD: no current model
    },
    "mrr_cm3_min": 191.2,
    "time_min": 0.452,
    "binding": ["force_N", "depth_mm"],
    "models": {"force_N": {"K": 1.8e3, "dK": 131.5, "version": 2}},
}


def per_operation_us(adapter: TypeAdapter[Any], n: int) -> float:
    """Mean time to validate ``ITEM`` and write it as JSON-ready data [µs]."""
    start = time.perf_counter()
    for _ in range(n):
        adapter.dump_python(adapter.validate_python(ITEM), mode="json")
    return (time.perf_counter() - start) / n * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--n", type=int, default=20000, help="operations per round")
    args = parser.parse_args()
    typed, free = TypeAdapter(HistoryOperation), TypeAdapter(FreeMapsOperation)
    assert typed.dump_python(typed.validate_python(ITEM), mode="json") == ITEM  # same answer
    times: dict[str, list[float]] = {"typed tables": [], "free maps (reference)": []}
    for _ in range(args.rounds):
        times["free maps (reference)"].append(per_operation_us(free, args.n))
        times["typed tables"].append(per_operation_us(typed, args.n))
    medians = {k: statistics.median(v) for k, v in times.items()}
    for name, median in medians.items():
        print(f"{name:24s} {median:7.2f} µs per operation (median of {args.rounds})")
    ratio = medians["typed tables"] / medians["free maps (reference)"]
    print(f"typed / free: {ratio:.2f}")


if __name__ == "__main__":
    main()
