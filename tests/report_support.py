"""Helpers of the HTML record tests (tests/api/test_report.py, test_report_cli.py,
test_report_layout.py): the demonstration plan with parts from the virtual lathe stored in a
SQLite database, one of them over the force limit, and its page."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
from sqlalchemy.engine import Engine

from api.report.html import render_html_report as render_report
from api.rest.schemas.parts import parse_report
from api.services import read as queries
from api.services.parts import report_part
from api.services.plans import create_plan
from db.engine import make_engine
from supervisor.inputs.plan import plan_from_mapping
from supervisor.rcb.update import start, update
from supervisor.virtual.sampling import sample_machine
from supervisor.virtual.simulate import run_part

from conftest import DEMO_PLAN
from migrated import migrated

BODY = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
PARTS = 10
#: Part index (0-based) whose rough-OD force is reported over the limit.
OVER_LIMIT = 3


def _reports(n, seed=3):
    """n part reports from the virtual lathe (as tests/api/test_service.py), one over the limit."""
    plan = plan_from_mapping(BODY)
    machine, rng, state = sample_machine(plan, seed), np.random.default_rng(seed), start(plan)
    bodies = []
    for i in range(n):
        outcome = run_part(
            machine, {op.name: op.setpoint for op in state.setpoints.operations}, rng
        )
        measured = {
            name: {q: {"value": m.value, "uncertainty": m.uncertainty} for q, m in ms.items()}
            for name, ms in outcome.measurements.items()
        }
        if i == OVER_LIMIT:
            measured["rough-od"]["force_N"] = {"value": 2100.0, "uncertainty": 3.0}
        body = {
            "serial": f"SN-{i + 1:04d}",
            "setpoint_version": state.version,
            "operations": [{"name": k, "measurements": v} for k, v in measured.items()],
        }
        bodies.append(body)
        state, _ = update(state, parse_report(body))
    return bodies


def stored_demo(folder: Path, parts: int) -> tuple[str, Engine, int]:
    """A SQLite database in ``folder`` with the demonstration plan and ``parts`` parts reported:
    its URL, an engine on it (the caller disposes of it) and the plan's id."""
    url = f"sqlite:///{folder / 'rcb.db'}"
    migrated(url)
    engine = make_engine(url)
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    for body in _reports(parts):
        report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
    return url, engine, plan_id


def stored_record(tmp_path_factory):
    """:func:`stored_demo` with :data:`PARTS` parts, read back: the database's URL, the plan's
    id, the plan, its history and its parts."""
    url, engine, plan_id = stored_demo(tmp_path_factory.mktemp("report"), PARTS)
    plan = queries.get_plan(engine=engine, plan_id=plan_id)
    parts = queries.parts(engine=engine, plan_id=plan_id, page_size=queries.MAX_PAGE)["items"]
    history = queries.plan_history(engine=engine, plan_id=plan_id)
    engine.dispose()
    return url, plan_id, plan, history, parts


def record_page(stored):
    """The HTML record of :func:`stored_record`'s plan."""
    _, _, plan, history, parts = stored
    return render_report(plan, history, parts)
