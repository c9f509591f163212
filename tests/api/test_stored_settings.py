"""A plan whose stored RCB settings fail this version's check keeps no plan from the list.

A check tightened in a later release (``z`` below 1 before migration 0025) leaves stored
settings that fail it: ``rcb plans`` and ``GET /plans`` then failed for every plan, naming
the plan's value (``--alpha = 5.0: must be a number in (0, 1]``). The list now shows such a
plan's settings as stored; a surface that uses the settings still says which value fails.
"""

from __future__ import annotations

import copy

import pytest
from sqlalchemy import update
from test_service import BODY

from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan
from api.services.read.plans import get_plan, list_plans
from api.services.read.setpoints import current_setpoints
from db import tables as t
from models.errors import InputError

from conftest import report_at

#: Values this version refuses: ``alpha`` in (0, 1], ``z`` at least 1 (migration 0025).
FAILING = {"alpha": 5.0, "z": 0.5}


def test_the_list_shows_the_stored_values_and_every_other_plan(engine):
    first = create_plan(engine=engine, body=BODY).body["id"]
    second = copy.deepcopy(BODY)
    second["name"] = "second-plan"
    other = create_plan(engine=engine, body=second).body["id"]
    with engine.begin() as c:
        stored = c.execute(t.Plan.__table__.select().where(t.Plan.id == first)).one().settings
        c.execute(update(t.Plan).where(t.Plan.id == first).values(settings={**stored, **FAILING}))
    page = list_plans(engine=engine)["plans"]
    assert [p["id"] for p in page] == [first, other]
    shown, fine = page
    assert (shown["alpha"], shown["settings"]["z"]) == (5.0, 0.5)  # as stored, not replaced
    assert shown["settings"]["coverage_k"] == stored["coverage_k"]
    assert (fine["alpha"], fine["settings"]["z"]) == (0.25, 4.0)  # the defaults
    assert get_plan(engine=engine, plan_id=first)["alpha"] == 5.0  # a read, as listed
    # the learner refuses them, naming the value (rcb replan too: no repair path yet)
    report = parse_report(report_at("SN-1", current_setpoints(engine=engine, plan_id=first)))
    with pytest.raises(InputError, match=r"alpha = 5\.0: must be a number in \(0, 1\]"):
        report_part(engine=engine, plan_id=first, report=report)
