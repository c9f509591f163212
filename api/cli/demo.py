"""``rcb demo``: the paper's demonstration part, RCB part by part on a virtual lathe (or mill).

Writes nothing: the parts are simulated in memory; :mod:`api.cli.demo_view` prints the result.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from api.cli import examples
from api.cli.common import JsonOption, StrategyOption, emit, err_console, errors
from supervisor.rcb.strategies import DEFAULT_ALPHA, DEFAULT_STRATEGY

_out = Console()

#: The paper's demonstration part: an example installed with the package (rcb examples).
DEMO_PLAN = "ivester_demo_part"
#: The milling demonstration (slot and side finish, spindle current as the force sensor).
MILLING_DEMO_PLAN = "milling_demo_part"

_PlanOption = Annotated[
    Path | None,
    typer.Option(
        "--plan",
        help="The plan (default: the installed example ivester_demo_part, or "
        "milling_demo_part with --milling; rcb examples).",
    ),
]
_MillingOption = Annotated[
    bool,
    typer.Option(
        "--milling",
        help="The milling demonstration (slot and side finish, spindle current as the "
        "force sensor) on a virtual mill.",
    ),
]


def demo(
    parts: Annotated[int, typer.Option("--parts", help="Parts made with RCB.", min=1)] = 20,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the virtual lathe.")] = 1,
    strategy: StrategyOption = DEFAULT_STRATEGY,
    alpha: Annotated[
        float, typer.Option("--alpha", help="Fraction of the margin a band shrinks by.")
    ] = DEFAULT_ALPHA,
    plan_file: _PlanOption = None,
    milling: _MillingOption = False,
    as_json: JsonOption = False,
) -> None:
    """The paper's demonstration: catalogue, robust start, then RCB part by part on a virtual lathe.

    With --milling: a slot and a side-finish pass on a virtual mill whose force is measured by
    the spindle current (Kim & Jeon). Writes nothing: the parts are simulated in memory.
    """
    # imported here (NumPy, SciPy, the solvers): rcb --help and the other commands do not load them
    from rich.progress import Progress

    from api.cli import demo_view
    from supervisor.inputs.plan import load_plan
    from supervisor.rcb.state import RcbSettings
    from supervisor.virtual.demo import MILLING_DEMO_UNCERTAINTY, run_demo

    with errors():
        settings = RcbSettings(strategy=strategy, alpha=alpha)
        if plan_file is None:
            with examples.example_path(MILLING_DEMO_PLAN if milling else DEMO_PLAN) as path:
                plan = load_plan(path)
        else:
            plan = load_plan(plan_file)
        u = MILLING_DEMO_UNCERTAINTY if milling else None
        if as_json:
            result = run_demo(plan, parts, seed, settings, uncertainty=u)
        else:
            where = "mill" if milling else "lathe"
            with Progress(console=err_console, transient=True) as progress:
                task = progress.add_task(f"RCB ({strategy}) on the virtual {where}", total=parts)
                result = run_demo(
                    plan,
                    parts,
                    seed,
                    settings,
                    lambda n: progress.update(task, completed=n),
                    uncertainty=u,
                )
    if as_json:
        emit(demo_view.demo_json(result, strategy, seed))
        return
    for table in demo_view.demo_tables(result):
        _out.print(table)
