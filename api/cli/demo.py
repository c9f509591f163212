"""``rcb demo``: the paper's demonstration part, RCB part by part on a virtual lathe (or mill).

The parts are simulated; the plan and every part are stored in an embedded SQLite database
(``rcb-demo.db`` here unless ``--db``) as a plant's are (:mod:`api.services.demo`), for ``rcb
history``, ``rcb report`` and ``rcb serve`` to show; :mod:`api.cli.demo_view` prints the result.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console

from api.cli import examples
from api.cli.common import (
    JsonOption,
    StrategyOption,
    as_option,
    emit,
    err_console,
    errors,
    say,
    shown,
)
from models.bounds import LARGEST_WHOLE
from models.errors import InputError
from supervisor.rcb.strategies import DEFAULT_ALPHA, DEFAULT_STRATEGY
from supervisor.virtual.sizes import MAX_PARTS

if TYPE_CHECKING:
    from supervisor.inputs.plan import Plan
    from supervisor.rcb.state import RcbSettings
    from supervisor.virtual.demo import Apply, DemoResult

_out = Console()

#: Where the demonstration is stored unless ``--db``: a file of its own in the working
#: directory, never ``RCB_DATABASE_URL`` (a plant's database gets no demonstration plans, and
#: its fleet no virtual machine's evidence).
DEMO_DATABASE = "sqlite:///rcb-demo.db"

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
_DemoDbOption = Annotated[
    str | None,
    typer.Option(
        "--db",
        help="Database URL the demonstration is stored in (default: ./rcb-demo.db; never "
        "$RCB_DATABASE_URL); migrated first.",
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
    parts: Annotated[
        int,
        typer.Option("--parts", help=f"Parts made with RCB (1-{MAX_PARTS}).", min=1, max=MAX_PARTS),
    ] = 20,
    seed: Annotated[
        int, typer.Option("--seed", help="Seed of the virtual lathe.", min=0, max=LARGEST_WHOLE)
    ] = 1,
    strategy: StrategyOption = DEFAULT_STRATEGY,
    alpha: Annotated[
        float, typer.Option("--alpha", help="Fraction of the margin a band shrinks by.")
    ] = DEFAULT_ALPHA,
    plan_file: _PlanOption = None,
    milling: _MillingOption = False,
    db: _DemoDbOption = None,
    as_json: JsonOption = False,
) -> None:
    """The paper's demonstration: catalogue, robust start, then RCB part by part on a virtual lathe.

    With --milling: a slot and a side-finish pass on a virtual mill whose force is measured by
    the spindle current (Kim & Jeon). The plan and its parts are stored in an embedded
    database (./rcb-demo.db unless --db) as a plant's are: rcb history and rcb report show
    them afterwards.
    """
    # imported here (NumPy, SciPy, the solvers): rcb --help and the other commands do not load them
    from api.cli import demo_view
    from api.cli.admin import migrate
    from api.cli.plans import read_plan_file
    from api.services.demo import demo_plan
    from api.services.demo import stored as store_parts
    from db.engine import make_engine
    from supervisor.inputs.plan import plan_from_mapping
    from supervisor.rcb.state import RcbSettings

    with errors():
        try:
            settings = RcbSettings(strategy=strategy, alpha=alpha)
        except InputError as err:
            raise as_option(err, ("alpha",)) from None
        with _plan_path(plan_file, milling) as path:
            body = read_plan_file(path, "plan file")  # read once, JSON or TOML
        plan = plan_from_mapping(body)
        url = db or DEMO_DATABASE
        migrate(url)
        engine = make_engine(url)
        try:
            stored = demo_plan(engine=engine, body=body, settings=settings)
            apply = store_parts(engine, stored["id"])
            result = _run(plan, parts, seed, settings, milling, apply, progress=not as_json)
        finally:
            engine.dispose()
    if as_json:
        where = shown(url)  # a password is never printed
        emit({**demo_view.demo_json(result, strategy, seed), "stored": _stored(stored, where)})
        return
    for table in demo_view.demo_tables(result):
        _out.print(table)
    say(demo_view.stored_line(stored["id"], stored["name"], shown(url)))


def _run(
    plan: Plan,
    parts: int,
    seed: int,
    settings: RcbSettings,
    milling: bool,
    apply: Apply,
    progress: bool,
) -> DemoResult:
    """The demonstration's parts, each applied by ``apply``; a progress bar on stderr."""
    from rich.progress import Progress

    from supervisor.virtual.demo import MILLING_DEMO_UNCERTAINTY, run_demo

    u = MILLING_DEMO_UNCERTAINTY if milling else None
    if not progress:
        return run_demo(plan, parts, seed, settings, uncertainty=u, apply=apply)
    where = "mill" if milling else "lathe"
    with Progress(console=err_console, transient=True) as bar:
        task = bar.add_task(f"RCB ({settings.strategy}) on the virtual {where}", total=parts)
        return run_demo(
            plan,
            parts,
            seed,
            settings,
            lambda n: bar.update(task, completed=n),
            uncertainty=u,
            apply=apply,
        )


def _stored(answer: dict[str, Any], url: str) -> dict[str, Any]:
    """Where the demonstration is stored (``--json``)."""
    return {"plan_id": answer["id"], "name": answer["name"], "database": url}


@contextmanager
def _plan_path(plan_file: Path | None, milling: bool) -> Iterator[Path]:
    """The plan file: ``--plan``, or the installed example of the demonstration."""
    if plan_file is not None:
        yield plan_file
        return
    with examples.example_path(MILLING_DEMO_PLAN if milling else DEMO_PLAN) as path:
        yield path
