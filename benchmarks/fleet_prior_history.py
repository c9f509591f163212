"""A new plan's fleet prior after a long history: the plant's stored plans copied many times.

``--plans`` plans of the demonstration program are made on ``--machines`` machines of the
virtual fleet through the real use cases (:mod:`fleet_prior_scale`), so that each machine has
its window of newest plans (:mod:`supervisor.fleet.window`); the script times the fleet's read
and the whole prior (best of 3), then copies every stored plan, with its operations and band
states, ``--copies`` times in SQL (what a year of the same plans would leave), and times them
again. Each machine speaks for a tool by its newest plans, so the two should be alike; the
last line is their ratio. It also prints the size of a new plan's ``GET /setpoints`` answer
and of its stored ``plans.prior`` (the provenance names at most ten plans and machines each:
:mod:`db.fleet_names`). Before alembic 0027 the evidence statement sought each picked plan's
operations among all the tool's (docs/benchmarks.md, "A machine's newest plans"). Run::

    .venv/bin/python benchmarks/fleet_prior_history.py [--machines 32] [--plans 320] [--copies 30]
"""

from __future__ import annotations

import argparse
import json
import sqlite3
import tempfile
from pathlib import Path
from typing import Any

from fleet_prior_scale import BODY, LEARN, _body, _make, _timed
from sqlalchemy import text

from api.services.plans import create_plan
from api.services.read.setpoints import current_setpoints
from db.engine import make_engine, upgrade
from supervisor.inputs.plan import plan_from_mapping
from supervisor.virtual.fleet import sample_fleet

#: The tables a plan's learned models live in, and the column that points at the parent row.
_COPIED = (("plans", None), ("operations", "plan_id"), ("band_states", "operation_id"))


def _copy(path: Path, copies: int) -> int:
    """Copy every stored plan ``copies`` times (new ids and names); the plans now stored."""
    with sqlite3.connect(path) as c:
        top = {
            table: c.execute(f"SELECT max(id) FROM {table}").fetchone()[0] for table, _ in _COPIED
        }
        for k in range(1, copies + 1):
            shift = {table: k * top[table] for table in top}
            parents = {"plan_id": shift["plans"], "operation_id": shift["operations"]}
            for table, parent in _COPIED:
                columns = [row[1] for row in c.execute(f"PRAGMA table_info({table})")]
                values = [
                    f"id + {shift[table]}"
                    if col == "id"
                    else f"name || '~{k}'"
                    if table == "plans" and col == "name"
                    else f"{col} + {parents[col]}"
                    if col == parent
                    else col
                    for col in columns
                ]
                c.execute(
                    f"INSERT INTO {table} ({', '.join(columns)}) SELECT {', '.join(values)}"
                    f" FROM {table} WHERE id <= {top[table]}"
                )
        return int(c.execute("SELECT count(*) FROM plans").fetchone()[0])


def _sizes(engine: Any, machines: int) -> None:
    """A new plan's ``GET /setpoints`` answer and its stored ``plans.prior``, in bytes."""
    made = create_plan(engine=engine, body=_body("sized", machines), settings=LEARN).body
    answer = current_setpoints(engine=engine, plan_id=made["id"])
    with engine.connect() as connection:
        stored = connection.execute(
            text("SELECT length(prior) FROM plans WHERE id = :id"), {"id": made["id"]}
        ).scalar()
    print(f"GET /setpoints {len(json.dumps(answer, default=str))} B, plans.prior {stored} B")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--machines", type=int, default=32)
    parser.add_argument("--plans", type=int, default=320)
    parser.add_argument("--copies", type=int, default=30)
    args = parser.parse_args()
    if not 1 <= args.machines <= 32 or not 1 <= args.plans <= 1000 or not 1 <= args.copies <= 100:
        parser.error("--machines must be 1..32, --plans 1..1000 and --copies 1..100")
    fleet = sample_fleet(plan_from_mapping(BODY), 11, args.machines)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "fleet.db"
        upgrade(f"sqlite:///{path}")
        engine = make_engine(f"sqlite:///{path}")
        for index in range(args.plans):
            _make(engine, fleet, index, args.machines, 2)
        print(f"{'plans stored':>12} {'models read':>12} {'read s':>8} {'prior s':>8}")
        rows = []
        for copies in (0, args.copies):
            stored = _copy(path, copies) if copies else args.plans
            engine.dispose()
            read, prior, models = _timed(engine, args.machines)
            rows.append(prior)
            print(f"{stored:>12} {models:>12} {read:>8.3f} {prior:>8.3f}")
            if not copies:
                _sizes(engine, args.machines)
        engine.dispose()
    print(f"prior after {args.copies} copies / before: {rows[1] / rows[0]:.2f}")


if __name__ == "__main__":
    main()
