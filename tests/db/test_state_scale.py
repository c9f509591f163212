"""A report's state read on a cache miss does not grow with the parts reported (issue 17, item 2).

SQLite counts the virtual-machine steps of the reads (a progress handler called at every step):
the work of reading rows, whatever the timer says. The old GROUP BY over every band-state row
and over every model version grew with the parts; the index seeks do not.
"""

from __future__ import annotations

import pytest
from scale_support import PLAN_ID, Copied
from sqlalchemy import func, select
from sqlalchemy.orm import Session
from test_service import BODY, _reports

from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan
from db import state as db_state
from db import tables as t
from db.model_versions import latest_models, version_numbers
from db.plan_state import plan_settings
from db.plans import get_plan_row
from db.refused import stored_plan
from supervisor.rcb.state import RcbSettings


def _steps(engine, plan_id):
    """The state as loaded on a cache miss, and the SQLite VM steps its reads took."""
    steps = [0]

    def tick() -> int:
        steps[0] += 1
        return 0

    with Session(engine) as session, session.begin():
        raw = session.connection().connection.driver_connection
        raw.set_progress_handler(tick, 1)
        try:
            row = get_plan_row(session=session, plan_id=plan_id)
            state = db_state._load_state(
                session, row, plan_settings(row), stored_plan(session=session, plan_row=row)
            )
            numbers = version_numbers(session=session, plan_id=plan_id)
        finally:
            raw.set_progress_handler(None, 1)
    return state, numbers, steps[0]


@pytest.mark.parametrize("strategy", ["bayes", "ivester"])
def test_a_cache_miss_reads_the_same_rows_at_20_and_at_300_parts(
    tmp_path, tmp_path_factory, strategy
):
    history = Copied(tmp_path_factory, tmp_path, strategy)  # the run's shared reports
    _, _, early = _steps(history.at(20), PLAN_ID)
    state, numbers, late = _steps(history.at(300), PLAN_ID)
    history.close()
    _, offline = _reports(300, settings=RcbSettings(strategy))
    # the state read is the one the offline replay of the same 300 reports reaches
    assert state.version == offline.version
    assert state.sigma == pytest.approx(offline.sigma)
    assert state.seen == pytest.approx(offline.seen)
    for name, tool in offline.tools.items():
        for q, model in tool.models.items():
            assert state.tools[name].models[q].dK == pytest.approx(model.dK), (name, q)
    assert max(numbers.values()) > 10  # the bands moved part after part
    assert late <= early * 1.15, (early, late)  # O(1): not 15x the parts, 15x the work


def test_latest_models_are_the_highest_versions(engine):
    """On both databases: the seek finds what max(version) found."""
    plan_id = create_plan(engine=engine, body=BODY, settings=RcbSettings("ivester")).body["id"]
    bodies, _ = _reports(5, settings=RcbSettings("ivester"))
    for body in bodies:
        report_part(engine=engine, plan_id=plan_id, report=parse_report(body))
    v = t.OperationModelVersion
    with Session(engine) as session:
        expected = {
            (o, q): n
            for o, q, n in session.execute(
                select(v.operation_id, v.quantity, func.max(v.version))
                .join(t.Operation, v.operation_id == t.Operation.id)
                .where(t.Operation.plan_id == plan_id)
                .group_by(v.operation_id, v.quantity)
            )
        }
        got = version_numbers(session=session, plan_id=plan_id)
        models = latest_models(session=session, plan_id=plan_id)
    assert got == expected and max(got.values()) > 1
    assert {k: r.version for k, r in models.items()} == expected
