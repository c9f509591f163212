"""Every RCB setting of a plan, and the learn posterior, survive a reload from the database."""

from __future__ import annotations

import tomllib

from sqlalchemy import select
from sqlalchemy.orm import Session

from api.services.parts import report_part
from api.services.plans import create_plan
from db import tables as t
from db.plan_state import settings_json, settings_of
from supervisor.rcb.state import RcbSettings

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
    )
    assert settings != RcbSettings(strategy="bayes", alpha=0.4)
    plan_id = create_plan(engine=engine, body=PLAN, settings=settings).body["id"]
    assert stored_state(engine, plan_id).settings == settings
    with Session(engine) as session:
        stored = session.scalars(select(t.Plan.settings).where(t.Plan.id == plan_id)).one()
    assert stored == settings_json(settings)


def test_a_plan_stored_before_0005_gets_the_defaults():
    assert settings_of("learn", 0.25, None) == RcbSettings(strategy="learn")
    assert settings_of("ivester", 0.3, {"z": 5.0}) == RcbSettings("ivester", alpha=0.3, z=5.0)


def test_the_learn_posterior_survives_a_reload_after_three_parts(engine):
    settings = RcbSettings(strategy="learn")
    created = create_plan(engine=engine, body=PLAN, settings=settings).body
    plan_id, setpoints = created["id"], created
    for i in range(3):
        body = report_at(f"L-{i}", setpoints)
        answer = report_part(engine=engine, plan_id=plan_id, body=body).body
        setpoints = answer
    in_memory = cached_state(engine, plan_id)
    assert len(in_memory.posterior) == 2 * len(PLAN["operations"])
    assert all(p.observations == 3 for p in in_memory.posterior.values())
    loaded = stored_state(engine, plan_id)
    assert loaded.posterior == in_memory.posterior
    assert loaded.settings == in_memory.settings == settings
    assert loaded.halt is None and loaded.version == in_memory.version
