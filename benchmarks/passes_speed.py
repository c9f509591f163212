"""Cost of whole passes (a script run on demand, not a test): an operation with ``stock_mm``
against the same operation in one continuous cut.

For the multi-pass operation of each pass example (``examples/turning_passes_part.toml``'s
``od-passes``, ``examples/milling_passes_part.toml``'s ``slot``) it times
``optimize_operation`` with its passes and without them (``passes=None``: the continuous
program), and prints the median of each over ``--repeat`` calls (warmed up first), their ratio
(the reference is the one-cut solve of the same run), and how many counts of passes the
search solved beside how many the depth bounds allow.

Run: ``python benchmarks/passes_speed.py [--repeat 200]``.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from pathlib import Path

from supervisor.inputs.plan import Operation, load_plan
from supervisor.optimize import passes
from supervisor.optimize.optimizer import optimize_operation
from supervisor.optimize.result import OperationResult

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
CASES = (("turning_passes_part", "od-passes"), ("milling_passes_part", "slot"))


def _median_ms(call: Callable[[], object], repeat: int) -> float:
    call()  # warm up
    samples = []
    for _ in range(repeat):
        start = time.perf_counter()
        call()
        samples.append(time.perf_counter() - start)
    return statistics.median(samples) * 1e3


def _case(file: str, name: str, repeat: int) -> str:
    """One example's line: the two medians, their ratio, the counts solved."""
    plan = load_plan(EXAMPLES / f"{file}.toml")
    op = next(o for o in plan.operations if o.name == name)
    tool, machine = plan.tools[op.tool], plan.machine
    assert op.passes is not None
    depths: list[float] = []

    def counting(pass_op: Operation) -> OperationResult:
        depths.append(pass_op.bounds[passes.DEPTH[op.process]][0])
        return optimize_operation(pass_op, tool, machine)

    result = passes.optimize_passes(op, tool, machine, counting)
    assert result.passes is not None
    solved = len(depths) - (op.passes.finish is not None)  # the finish is one solve
    low, high = op.bounds[passes.DEPTH[op.process]]
    stock = op.passes.roughing_stock_mm
    allowed = math.floor(stock / low) - math.ceil(stock / high) + 1
    with_passes = _median_ms(partial(optimize_operation, op, tool, machine), repeat)
    one_cut = replace(op, passes=None)
    continuous = _median_ms(partial(optimize_operation, one_cut, tool, machine), repeat)
    return (
        f"{file}:{name}: {result.passes.count} passes; with passes {with_passes:.2f} ms, "
        f"one cut {continuous:.2f} ms (ratio {with_passes / continuous:.1f}); "
        f"counts solved {solved} of {allowed} the depth bounds allow"
    )


def main() -> None:
    """Print, per example, the two medians, their ratio and the counts solved."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--repeat", type=int, default=200, help="calls per figure (1-10000)")
    repeat = min(max(parser.parse_args().repeat, 1), 10_000)
    for file, name in CASES:
        print(_case(file, name, repeat))


if __name__ == "__main__":
    main()
