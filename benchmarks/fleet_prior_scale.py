"""A new plan's fleet prior as the plant's history grows (supervisor.fleet.window).

Plans of the demonstration program are made on ``--machines`` machines of the virtual fleet
(:func:`supervisor.virtual.fleet.sample_fleet`), each with ``--parts`` parts through the real
use cases (``create_plan``, ``report_part``) into one SQLite file, round-robin over the
machines. At each size of ``--sizes`` (plans stored) the script times, best of 3, the fleet's
read of the new plan's tools (``db.fleet.fleet_evidence``) and the whole prior
(``db.fleet.plan_priors``: the read and the hierarchical model), and counts the learned models
read. Each machine speaks for a tool by its newest plans, so from the size where every
machine has that many the figures stay put; the last line is the ratio of the largest size's
prior to the smallest's. Run::

    .venv/bin/python benchmarks/fleet_prior_scale.py [--sizes 30 300] [--machines 3] [--parts 2]
"""

from __future__ import annotations

import argparse
import copy
import tempfile
import time
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
from sqlalchemy import Engine
from sqlalchemy.orm import Session

from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan
from api.services.read.setpoints import current_setpoints
from db.engine import make_engine, upgrade
from db.fleet import fleet_evidence, plan_priors
from supervisor.fleet.window import PLANS_PER_MACHINE
from supervisor.inputs.plan import plan_from_mapping
from supervisor.rcb.state import RcbSettings
from supervisor.virtual.fleet import sample_fleet
from supervisor.virtual.simulate import run_part

ROOT = Path(__file__).resolve().parent.parent
BODY = tomllib.loads((ROOT / "examples" / "ivester_demo_part.toml").read_text(encoding="utf-8"))
LEARN = RcbSettings(strategy="learn")


def _body(name: str, machine: int) -> dict[str, Any]:
    body = copy.deepcopy(BODY)
    body["name"], body["machine"]["name"] = name, f"lathe-{machine}"
    return body


def _make(engine: Engine, fleet: Any, index: int, machines: int, parts: int) -> None:
    """Plan ``index`` on machine ``index % machines``, ``parts`` parts of it reported."""
    machine = index % machines
    made = create_plan(engine=engine, body=_body(f"p{index}", machine), settings=LEARN)
    plan_id = made.body["id"]
    rng = np.random.default_rng([machine, index])
    for i in range(parts):
        current = current_setpoints(engine=engine, plan_id=plan_id)
        setpoints = {op["name"]: op["setpoint"] for op in current["operations"]}
        outcome = run_part(fleet[machine], setpoints, rng)
        body = outcome.report(f"p{index}-{i}", current["setpoint_version"])
        report_part(engine=engine, plan_id=plan_id, report=parse_report(body))


def _timed(engine: Engine, machines: int) -> tuple[float, float, int]:
    """Best of 3: the fleet's read, the whole prior (seconds), and the models read."""
    plan = plan_from_mapping(_body("new", machines))
    tools = [op.tool for op in plan.operations]
    best = (float("inf"), float("inf"), 0)
    for _ in range(3):
        with Session(engine) as session:
            start = time.perf_counter()
            learned = fleet_evidence(session=session, tool_names=tools)
            read = time.perf_counter() - start
            start = time.perf_counter()
            plan_priors(session=session, plan=plan, settings=LEARN, prior=None)
            prior = time.perf_counter() - start
        best = min(best, (read, prior, len(learned)), key=lambda x: x[1])
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[30, 300])
    parser.add_argument("--machines", type=int, default=3)
    parser.add_argument("--parts", type=int, default=2)
    args = parser.parse_args()
    if not 1 <= args.machines <= 32 or not 1 <= args.parts <= 30:
        parser.error("--machines must be 1..32 and --parts 1..30")
    if not all(1 <= size <= 5000 for size in args.sizes):
        parser.error("--sizes must be 1..5000")
    fleet = sample_fleet(plan_from_mapping(BODY), 11, args.machines)
    with tempfile.TemporaryDirectory() as folder:
        url = f"sqlite:///{Path(folder) / 'fleet.db'}"
        upgrade(url)
        engine = make_engine(url)
        print(
            f"{args.machines} machines, {args.parts} parts a plan, the newest "
            f"{PLANS_PER_MACHINE} plans of each machine per tool"
        )
        print(f"{'plans':>6} {'models read':>12} {'read s':>8} {'prior s':>8}")
        made, rows = 0, []
        for size in sorted(args.sizes):
            while made < size:
                _make(engine, fleet, made, args.machines, args.parts)
                made += 1
            read, prior, models = _timed(engine, args.machines)
            rows.append(prior)
            print(f"{size:>6} {models:>12} {read:>8.3f} {prior:>8.3f}")
        engine.dispose()
    print(f"prior at {max(args.sizes)} plans / at {min(args.sizes)}: {rows[-1] / rows[0]:.2f}")


if __name__ == "__main__":
    main()
