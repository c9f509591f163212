"""A new plan's read of imported models as ``imported_models`` grows (db.fleet_window).

One plan of the demonstration program learns on a virtual lathe (two parts, through the real
use cases) and its models of ``CNMG432RN`` are exported; their items are the templates of
``--sizes`` rows each of ``imported_models`` in one SQLite file, on ``--machines`` imported
machines of one origin, each plan two rows (two quantities), newer plans later. At each size
the script times, best of 5, the fleet's read of the tool's imported models
(``db.fleet_imported.imported_evidence``: the window, the rows and reading them back) and
the window's statement alone (``db.fleet_window.newest_imported``), and counts the models read: each
machine speaks by its newest :data:`~supervisor.fleet.window.PLANS_PER_MACHINE` plans, so the
count stays put. The last lines are the ratios of the largest size's times to the smallest's.
``--import-cost ROWS`` also times writing ROWS rows into an empty table as it is and with
``ix_imported_models_tool`` dropped (a prefix of two other indexes), alternated, best of 3.
Run::

    .venv/bin/python benchmarks/imported_window.py [--sizes 1000 20000] [--machines 5]
        [--import-cost 20000]
"""

from __future__ import annotations

import argparse
import copy
import tempfile
import time
import tomllib
import uuid
from pathlib import Path
from typing import Any

import numpy as np
from sqlalchemy import Engine, Subquery, func, insert, select
from sqlalchemy.orm import Session

from api.rest.schemas.parts import parse_report
from api.services.fleet_models import export_tool
from api.services.parts import report_part
from api.services.plans import create_plan
from api.services.read.setpoints import current_setpoints
from db import tables as t
from db.engine import make_engine, upgrade
from db.fleet_imported import imported_evidence
from db.fleet_window import newest_imported
from supervisor.fleet.window import PLANS_PER_MACHINE
from supervisor.inputs.plan import plan_from_mapping
from supervisor.rcb.state import RcbSettings
from supervisor.virtual.fleet import sample_fleet
from supervisor.virtual.simulate import run_part

ROOT = Path(__file__).resolve().parent.parent
BODY = tomllib.loads((ROOT / "examples" / "ivester_demo_part.toml").read_text(encoding="utf-8"))
LEARN = RcbSettings(strategy="learn")
TOOL = "CNMG432RN"
ORIGIN = str(uuid.UUID(int=0x6F1C2A3B << 96, version=4))
BATCH = 2000


def _templates(folder: Path) -> list[dict[str, Any]]:
    """The items of a learned plan's export of :data:`TOOL` (one a quantity)."""
    url = f"sqlite:///{folder / 'learned.db'}"
    upgrade(url)
    engine = make_engine(url)
    body = copy.deepcopy(BODY)
    body["name"], body["machine"]["name"] = "learned", "lathe-0"
    plan_id = create_plan(engine=engine, body=body, settings=LEARN).body["id"]
    fleet = sample_fleet(plan_from_mapping(BODY), 11, 1)
    rng = np.random.default_rng(11)
    for i in range(2):
        current = current_setpoints(engine=engine, plan_id=plan_id)
        setpoints = {op["name"]: op["setpoint"] for op in current["operations"]}
        outcome = run_part(fleet[0], setpoints, rng)
        report = outcome.report(f"learned-{i}", current["setpoint_version"])
        report_part(engine=engine, plan_id=plan_id, report=parse_report(report))
    items = export_tool(engine=engine, tool=TOOL)["learned"]
    engine.dispose()
    for item in items:
        del item["origin"]
    return list(items)


def _fill(
    engine: Engine, templates: list[dict[str, Any]], start: int, end: int, machines: int
) -> None:
    """Rows ``start`` … ``end - 1``: plan ``row // len(templates)`` round-robin on the machines."""
    per_plan = len(templates)
    rows = []
    for row in range(start, end):
        plan, item = divmod(row, per_plan)
        machine = f"lathe-{plan % machines}"
        body = {**templates[item], "machine": machine, "plan": f"p{plan}"}
        rows.append(
            {
                "tool": TOOL,
                "origin": ORIGIN,
                "machine": machine,
                "plan": f"p{plan}",
                "operation": body["operation"]["name"],
                "quantity": body["posterior"]["quantity"],
                "observations": body["posterior"].get("observations", 0),
                "body": body,
                "source": f"bench.json: p{plan} on {machine}",
            }
        )
        if len(rows) == BATCH or row == end - 1:
            with Session(engine) as session, session.begin():
                session.execute(insert(t.core_table(t.ImportedModel)), rows)
            rows = []


def _grouped(tool_names: list[str], n: int = PLANS_PER_MACHINE) -> Subquery:
    """The window before alembic 0031, the reference: every row of the tools grouped by plan."""
    m = t.ImportedModel
    per_plan = (
        select(m.tool, m.origin, m.machine, m.plan, func.max(m.id).label("last"))
        .where(m.tool.in_(tool_names))
        .group_by(m.tool, m.origin, m.machine, m.plan)
        .subquery()
    )
    c = per_plan.c
    rank = func.row_number().over(
        partition_by=(c.tool, c.origin, c.machine), order_by=c.last.desc()
    )
    ranked = select(c.tool, c.origin, c.machine, c.plan, rank.label("rank")).subquery()
    return select(ranked.c[:4]).where(ranked.c.rank <= n).subquery()


def _timed(engine: Engine) -> tuple[float, float, float, int]:
    """Best of 5: the fleet's imported read, the window, the grouped reference (seconds), and
    the models read; the window and the reference must pick the same plans."""
    read, window, grouped, models = float("inf"), float("inf"), float("inf"), 0
    for _ in range(5):
        with Session(engine) as session:
            start = time.perf_counter()
            models = len(imported_evidence(session=session, tool_names=[TOOL]))
            read = min(read, time.perf_counter() - start)
            start = time.perf_counter()
            walked = session.execute(select(newest_imported([TOOL], "sqlite"))).all()
            window = min(window, time.perf_counter() - start)
            start = time.perf_counter()
            reference = session.execute(select(_grouped([TOOL]))).all()
            grouped = min(grouped, time.perf_counter() - start)
            assert sorted(map(tuple, walked)) == sorted(map(tuple, reference))
    return read, window, grouped, models


def _import_cost(folder: Path, templates: list[dict[str, Any]], rows: int, machines: int) -> None:
    """Writing ``rows`` imported rows with and without the tool's own index, best of 3 each."""
    best = {False: float("inf"), True: float("inf")}
    size = {False: 0, True: 0}
    for run in range(6):
        without = bool(run % 2)
        url = f"sqlite:///{folder / f'cost-{run}.db'}"
        upgrade(url)
        engine = make_engine(url)
        if without:
            with engine.begin() as connection:
                connection.exec_driver_sql("DROP INDEX ix_imported_models_tool")
        start = time.perf_counter()
        _fill(engine, templates, 0, rows, machines)
        best[without] = min(best[without], time.perf_counter() - start)
        engine.dispose()
        size[without] = (folder / f"cost-{run}.db").stat().st_size
    print(
        f"writing {rows} imported rows: {best[False]:.3f} s as now, {best[True]:.3f} s without "
        f"ix_imported_models_tool: {best[True] / best[False]:.2f}; the file "
        f"{size[False] / 2**20:.2f} MiB, {size[True] / 2**20:.2f} MiB"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 20000])
    parser.add_argument("--machines", type=int, default=5)
    parser.add_argument("--import-cost", type=int, default=0, metavar="ROWS")
    args = parser.parse_args()
    if not 0 <= args.import_cost <= 200_000:
        parser.error("--import-cost must be 0..200000")
    if not 1 <= args.machines <= 100:
        parser.error("--machines must be 1..100")
    if not all(1 <= size <= 200_000 for size in args.sizes):
        parser.error("--sizes must be 1..200000")
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        templates = _templates(folder)
        url = f"sqlite:///{folder / 'imported.db'}"
        upgrade(url)
        engine = make_engine(url)
        print(
            f"{args.machines} imported machines, {len(templates)} models a plan, the newest "
            f"{PLANS_PER_MACHINE} plans of each machine per tool"
        )
        print(f"{'rows':>7} {'models read':>12} {'read s':>8} {'window s':>9} {'grouped s':>10}")
        stored, figures = 0, []
        for size in sorted(args.sizes):
            _fill(engine, templates, stored, size, args.machines)
            stored = size
            read, window, grouped, models = _timed(engine)
            figures.append((read, window, grouped))
            print(f"{size:>7} {models:>12} {read:>8.4f} {window:>9.4f} {grouped:>10.4f}")
        engine.dispose()
        if args.import_cost:
            _import_cost(folder, templates, args.import_cost, args.machines)
    first, last = figures[0], figures[-1]
    large, small = max(args.sizes), min(args.sizes)
    for i, label in enumerate(("read", "window", "grouped reference (before 0031)")):
        print(f"{label} at {large} rows / at {small}: {last[i] / first[i]:.2f}")


if __name__ == "__main__":
    main()
