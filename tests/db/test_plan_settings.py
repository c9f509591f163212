"""Every RCB setting of a plan, and the learn posterior, survive a reload from the database."""

from __future__ import annotations

import math
import tomllib

import pytest
from sqlalchemy import select, update
from sqlalchemy.orm import Session

from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan
from api.services.read import current_setpoints
from db import tables as t
from db.plan_state import settings_json, settings_of
from models.errors import InputError
from supervisor.rcb.state import DEFAULT_HALT_OVER, RcbSettings

from conftest import DEMO_PLAN, cached_state, report_at, stored_state

PLAN = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))


def test_non_default_settings_survive_a_reload(engine):
    settings = RcbSettings(
        strategy="bayes",
        alpha=0.4,
        floors={"force_N": 25.0, "roughness_um": 0.1},
        coverage_k=3.0,
        discrepancy=0.05,
        z=3.5,
        exponent_sd=0.2,
        edge_sd=0.3,
        halt_over=0.6,
    )
    assert settings != RcbSettings(strategy="bayes", alpha=0.4)
    plan_id = create_plan(engine=engine, body=PLAN, settings=settings).body["id"]
    assert stored_state(engine, plan_id).settings == settings
    with Session(engine) as session:
        stored = session.scalars(select(t.Plan.settings).where(t.Plan.id == plan_id)).one()
    assert stored == settings_json(settings)


def test_a_plan_stored_before_0005_gets_the_defaults():
    assert settings_of(None) == RcbSettings(strategy="learn")
    assert settings_of({"strategy": "ivester", "alpha": 0.3, "z": 5.0}) == RcbSettings(
        "ivester", alpha=0.3, z=5.0
    )


def test_halt_over_defaults_to_a_quarter_and_is_stored_with_the_plan():
    assert DEFAULT_HALT_OVER == 0.25 and RcbSettings().halt_over == 0.25
    assert settings_json(RcbSettings(halt_over=2.5))["halt_over"] == 2.5
    assert settings_of({"strategy": "ivester", "halt_over": 0.1}).halt_over == 0.1


def test_a_plan_stored_before_halt_over_reads_the_default(engine):
    """A settings column written before the key existed: the default, no migration."""
    plan_id = create_plan(engine=engine, body=PLAN, settings=RcbSettings(halt_over=3.0)).body["id"]
    assert stored_state(engine, plan_id).settings.halt_over == 3.0
    older = settings_json(RcbSettings())
    del older["halt_over"]
    with Session(engine) as session, session.begin():
        session.execute(update(t.Plan).where(t.Plan.id == plan_id).values(settings=older))
    assert stored_state(engine, plan_id).settings.halt_over == DEFAULT_HALT_OVER


@pytest.mark.parametrize("value", [0.0, -0.25, 10.5, math.inf, math.nan])
def test_halt_over_outside_0_to_10_is_refused_naming_it(value):
    with pytest.raises(InputError) as refused:
        RcbSettings(halt_over=value)
    assert refused.value.field == "halt_over"
    assert "halt_over" in str(refused.value) and str(value) in str(refused.value)


def test_halt_over_of_10_is_the_largest_taken():
    assert RcbSettings(halt_over=10.0).halt_over == 10.0
    assert RcbSettings(halt_over=1e-6).halt_over == 1e-6


def test_the_learn_posterior_survives_a_reload_after_three_parts(engine):
    settings = RcbSettings(strategy="learn")
    created = create_plan(engine=engine, body=PLAN, settings=settings).body
    plan_id, setpoints = created["id"], created
    for i in range(3):
        body = report_at(f"L-{i}", setpoints)
        answer = report_part(engine=engine, plan_id=plan_id, report=parse_report(body)).body
        setpoints = answer
    in_memory = cached_state(engine, plan_id)
    assert len(in_memory.posterior) == 2 * len(PLAN["operations"])
    assert all(p.observations == 3 for p in in_memory.posterior.values())
    loaded = stored_state(engine, plan_id)
    assert loaded.posterior == in_memory.posterior
    assert loaded.settings == in_memory.settings == settings
    assert loaded.halt is None and loaded.version == in_memory.version


@pytest.mark.parametrize("value", [1e-3, 0.49, 4.7e-294])
def test_a_coverage_k_below_a_half_is_refused_naming_it(value):
    """A band narrower than half a standard deviation: the prior's ln K variance
    ((ΔK/K)/k)² was so wide that a learn plan's first report overflowed (a 500 from
    ``POST /plans?coverage_k=4.7e-294`` then a part, found by schemathesis)."""
    with pytest.raises(InputError) as refused:
        RcbSettings(strategy="learn", coverage_k=value)
    assert refused.value.field == "coverage_k"


def test_a_coverage_k_of_a_half_learns_from_a_report(engine):
    """The least k taken: the demo plan's first part is learned, its prior finite."""
    plan_id = create_plan(
        engine=engine, body=PLAN, settings=RcbSettings(strategy="learn", coverage_k=0.5)
    ).body["id"]
    body = report_at("k-1", current_setpoints(engine=engine, plan_id=plan_id))
    assert report_part(engine=engine, plan_id=plan_id, report=parse_report(body)).status == 201
    state = stored_state(engine, plan_id)
    assert state.posterior and all(
        math.isfinite(v) for b in state.posterior.values() for row in b.cov for v in row
    )
