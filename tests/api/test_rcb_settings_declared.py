"""RCB settings declared once (issue 31 item 2): ``alpha`` reaches the law from a plan file's
``[rcb]`` table, from ``rcb replan --rcb`` and from REST; bad settings are named.

Each test reports one part measured at its predictions (positive margins) and checks that the
bands shrank by the alpha given, not the paper's default 0.25.
"""

from __future__ import annotations

import json
import tomllib

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from api.cli.main import app
from api.rest.app import create_app
from api.rest.schemas.parts import parse_report
from api.services.parts import report_part
from api.services.plans import create_plan
from db.api_keys import create_key
from supervisor.rcb.settings import SETTINGS
from supervisor.rcb.state import RcbSettings

from conftest import DEMO_PLAN, engine_url, renamed, report_at, stored_state

PLAN = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))


def _shrink_fractions(answer: dict) -> list[float]:
    """``(band_before - band_after) / margin`` of each band the law shrank by its fraction."""
    return [
        (u["band_before"] - u["band_after"]) / u["margin"]
        for u in answer["updates"]
        if u["action"] == "shrink" and "band shrinks by" in u["reason"]
    ]


def _alpha_reached_the_law(engine, plan_id: int, alpha: float) -> None:
    state = stored_state(engine, plan_id)
    assert state.settings.alpha == alpha
    setpoints = {
        "setpoint_version": state.version,
        "operations": [
            {"name": op.name, "predicted": {q: {"value": p.value} for q, p in op.predicted.items()}}
            for op in state.setpoints.operations
        ],
    }
    serial = f"SN-{state.version}"
    answer = report_part(
        engine=engine, plan_id=plan_id, report=parse_report(report_at(serial, setpoints))
    ).body
    fractions = _shrink_fractions(answer)
    assert fractions, answer["updates"]
    assert fractions == pytest.approx([alpha] * len(fractions), rel=1e-9)


def test_alpha_from_a_plan_file_reaches_the_law(engine, runner, tmp_path):
    text = DEMO_PLAN.read_text(encoding="utf-8").replace('name = "', 'name = "rcb-file-', 1)
    plan_file = tmp_path / "plan.toml"
    plan_file.write_text(text + '\n[rcb]\nstrategy = "ivester"\nalpha = 0.5\n', encoding="utf-8")
    url = engine_url(engine)
    done = runner.invoke(app, ["plans", "create", str(plan_file), "--db", url, "--json"])
    assert done.exit_code == 0, done.output
    _alpha_reached_the_law(engine, json.loads(done.stdout)["id"], 0.5)


def test_alpha_from_rcb_replan_reaches_the_law(engine, runner):
    plan_id = create_plan(engine=engine, body=renamed(PLAN), settings=RcbSettings("ivester")).body[
        "id"
    ]
    url = engine_url(engine)
    done = runner.invoke(app, ["replan", str(plan_id), "--rcb", "alpha=0.3", "--db", url])
    assert done.exit_code == 0, done.output
    state = stored_state(engine, plan_id)
    assert state.settings == RcbSettings("ivester", alpha=0.3)  # the others stay
    _alpha_reached_the_law(engine, plan_id, 0.3)


def _client(engine) -> TestClient:
    with Session(engine) as session, session.begin():
        _, key = create_key(session=session, role="engineer")
    url = engine_url(engine)
    return TestClient(create_app(url), headers={"Authorization": f"Bearer {key}"})


def test_alpha_from_rest_reaches_the_law(engine):
    client = _client(engine)
    body = {**renamed(PLAN), "rcb": {"strategy": "ivester", "alpha": 0.6}}
    created = client.post("/api/v1/plans", json=body)
    assert created.status_code == 201, created.text
    plan_id = created.json()["id"]
    assert client.get(f"/api/v1/plans/{plan_id}").json()["alpha"] == 0.6
    _alpha_reached_the_law(engine, plan_id, 0.6)
    replanned = client.post(f"/api/v1/plans/{plan_id}/replan", json={"rcb": {"alpha": 0.4}})
    assert replanned.status_code == 201, replanned.text
    _alpha_reached_the_law(engine, plan_id, 0.4)
    # a query parameter takes precedence over the body's table
    other = client.post("/api/v1/plans", json=renamed(body), params={"alpha": 0.2})
    assert other.status_code == 201, other.text
    assert stored_state(engine, other.json()["id"]).settings.alpha == 0.2


def test_bad_settings_are_named_with_their_value(engine, runner, tmp_path):
    client = _client(engine)
    for rcb, field in (({"alpha": 1.5}, "rcb.alpha"), ({"alfa": 0.3}, "rcb.alfa")):
        refused = client.post("/api/v1/plans", json={**renamed(PLAN), "rcb": rcb})
        assert refused.status_code == 422, refused.text
        assert refused.headers["content-type"].startswith("application/problem+json")
        assert refused.json()["field"] == field
    url = engine_url(engine)
    plan_file = tmp_path / "plan.toml"
    for table, words in (
        ("alpha = 1.5", ["rcb.alpha", "1.5", "(0, 1]"]),
        ("alfa = 0.3", ["rcb", "alfa"]),
        ('strategy = "guess"', ["rcb.strategy", "guess"]),
    ):
        plan_file.write_text(DEMO_PLAN.read_text(encoding="utf-8") + f"\n[rcb]\n{table}\n")
        done = runner.invoke(app, ["plans", "create", str(plan_file), "--db", url])
        assert done.exit_code == 2 and "Traceback" not in done.output
        assert all(w in done.stderr for w in words), done.stderr
    for option, words in (
        ("alpha=0", ["--rcb alpha", "0"]),
        ("beta=1", ["--rcb beta = '1': unknown setting 'beta'; one of: strategy, alpha"]),
        ("alfa=0.3", ["--rcb alfa = '0.3': unknown setting 'alfa' (did you mean 'alpha'?)"]),
        ("floors=5", ["--rcb floors = '5': give each floor as floors.QUANTITY=VALUE"]),
        ("alpha.force_N=0.3", ["--rcb alpha.force_N = '0.3': alpha is one setting"]),
        ("alpha", ["--rcb = 'alpha': must be NAME=VALUE, NAME one of: strategy, alpha"]),
    ):
        done = runner.invoke(app, ["replan", "1", "--rcb", option, "--db", url])
        assert done.exit_code == 2 and "Traceback" not in done.output
        assert all(w in done.stderr for w in words), done.stderr


def test_the_settings_and_their_defaults_are_declared_once():
    defaults = RcbSettings(discrepancy=None)
    for name, setting in SETTINGS.items():
        if setting.default is not None:
            assert getattr(defaults, name) == setting.default_value(), name
    assert list(SETTINGS) == list(RcbSettings.__dataclass_fields__)


def test_strategy_on_the_command_line_takes_precedence_over_the_file(engine, runner, tmp_path):
    url = engine_url(engine)
    text = DEMO_PLAN.read_text(encoding="utf-8")
    for n, (options, strategy) in enumerate(
        (([], "bayes"), (["--strategy", "ivester"], "ivester"), (["--rcb", "z=5"], "bayes"))
    ):
        plan_file = tmp_path / f"plan{n}.toml"
        named = text.replace('name = "', f'name = "precedence-{n}-', 1)
        plan_file.write_text(named + '\n[rcb]\nstrategy = "bayes"\n', encoding="utf-8")
        done = runner.invoke(app, ["plans", "create", str(plan_file), "--db", url, *options])
        assert done.exit_code == 0, done.output
        plan_id = int(done.stderr.split("rcb: plan ")[1].split()[0])
        assert stored_state(engine, plan_id).settings.strategy == strategy
