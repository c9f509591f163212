"""A JSON plan file at every command that reads a plan file, as ``rcb plans create`` reads it.

Before, ``rcb optimize plan.json`` and ``rcb demo --plan plan.json`` said ``plan file =
'plan.json': is not valid TOML`` while ``rcb plans create plan.json`` stored the plan
(docs/guide/plan-files.md: one reader). Now each reads ``*.json`` as JSON and anything else as
TOML (:func:`supervisor.inputs.plan.read_plan`), a JSON ``null`` as the field left out.
"""

from __future__ import annotations

import json
import tomllib

import pytest

from conftest import DEMO_PLAN, invoke


@pytest.fixture
def plan_json(tmp_path):
    """The demonstration plan as JSON, its optional descriptions ``null``."""
    plan = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
    plan["description"] = None
    plan["operations"][0]["description"] = None
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(plan), encoding="utf-8")
    return path


def test_optimize_reads_a_json_plan_as_its_toml(runner, plan_json):
    from_json = invoke(runner, "optimize", str(plan_json), "--json")
    assert from_json.exit_code == 0, from_json.stderr
    from_toml = invoke(runner, "optimize", str(DEMO_PLAN), "--json")
    assert from_toml.exit_code == 0, from_toml.stderr
    assert json.loads(from_json.stdout) == json.loads(from_toml.stdout)
    table = invoke(runner, "optimize", str(plan_json))
    assert table.exit_code == 0 and "cycle time 1.398 min" in table.stdout, table.stderr


def test_optimize_says_a_broken_json_plan_is_not_valid_json(runner, tmp_path):
    broken = tmp_path / "broken.json"
    broken.write_text("{not json", encoding="utf-8")
    done = invoke(runner, "optimize", str(broken))
    assert done.exit_code == 2 and len(done.stderr.splitlines()) == 1, done.stderr
    assert done.stderr.startswith(f"rcb: error: plan file = '{broken}': is not valid JSON (")


def test_demo_and_plans_create_read_the_same_json_plan(runner, plan_json, tmp_path):
    db = f"sqlite:///{tmp_path / 'demo.db'}"
    demo = invoke(runner, "demo", "--plan", str(plan_json), "--parts", "1", "--db", db)
    assert demo.exit_code == 0, demo.stderr
    assert "rough-od" in demo.stdout and "rcb: stored in" in demo.stderr
    created = invoke(runner, "plans", "create", str(plan_json), "--db", db, "--json")
    assert created.exit_code == 2  # the demo stored the plan by its name: the same plan read
    assert "ivester-demo-part" in created.stderr, created.stderr
    renamed = json.loads(plan_json.read_text(encoding="utf-8")) | {"name": "from-json"}
    plan_json.write_text(json.dumps(renamed), encoding="utf-8")
    created = invoke(runner, "plans", "create", str(plan_json), "--db", db, "--json")
    assert created.exit_code == 0, created.stderr  # nulls left out, as POST /plans takes them
    assert json.loads(created.stdout)["cycle_time_min"] == pytest.approx(1.398, abs=5e-4)
