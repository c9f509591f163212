"""Plans by name (issue 30, point 2) on SQLite and PostgreSQL.

``rcb plans create FILE`` stores a plan by its name, ``rcb plans show PLAN`` and every PLAN
argument take the id or the name, a name names one plan (a second create is refused on the
command line and over REST: 409 ``plan_name_taken``), and alembic 0011 upgrades a database
that already holds plans of one name (the oldest keeps it, later ones become ``NAME#ID``).
"""

from __future__ import annotations

import json
import tomllib

from sqlalchemy import text
from test_migrations import _no_difference  # autogenerate finds nothing, every table there

from api.cli.main import app
from db.engine import make_engine, upgrade
from db.tables import utcnow

from conftest import DEMO_PLAN
from migrated import migrated

PLAN = tomllib.loads(DEMO_PLAN.read_text(encoding="utf-8"))
NAME = PLAN["name"]


def _rcb(runner, *args):
    return runner.invoke(app, [str(a) for a in args])


def _one_line_error(result, *words):
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rcb: error: "), result.stderr
    assert all(w in lines[0] for w in words), lines[0]
    assert "Traceback" not in result.output


def test_create_show_list_and_history_by_name(runner, backend_url, tmp_path):
    migrated(backend_url)
    created = _rcb(runner, "plans", "create", DEMO_PLAN, "--db", backend_url, "--json")
    assert created.exit_code == 0, created.output
    plan = json.loads(created.stdout)
    assert (plan["name"], plan["setpoint_version"]) == (NAME, 1)
    assert plan["cycle_time_min"] > 0 and len(plan["operations"]) == len(PLAN["operations"])

    table = _rcb(runner, "plans", "create", DEMO_PLAN, "--db", backend_url)  # the same name
    _one_line_error(table, "name", NAME, f"plan {plan['id']} has this name", "rcb replan")
    # told before the prior is looked for (before: "no learn plan in the fleet ...", then this)
    fleet = _rcb(runner, "plans", "create", DEMO_PLAN, "--db", backend_url, "--prior", "fleet")
    _one_line_error(fleet, "name", NAME, f"plan {plan['id']} has this name")

    other = tmp_path / "other.json"  # JSON of the same structure, as POST /plans takes it
    other.write_text(json.dumps({**PLAN, "name": "second-part"}), encoding="utf-8")
    second = _rcb(runner, "plans", "create", other, "--db", backend_url, "--strategy", "ivester")
    assert second.exit_code == 0, second.output
    assert f"{NAME}" not in second.stdout and "second-part" in second.stdout
    assert "setpoint version 1, cycle time" in second.stderr

    for listing in (["plans"], ["plans", "list"]):
        listed = json.loads(_rcb(runner, *listing, "--db", backend_url, "--json").stdout)
        assert [p["name"] for p in listed["plans"]] == [NAME, "second-part"]

    by_name = _rcb(runner, "plans", "show", NAME, "--db", backend_url, "--json")
    by_id = _rcb(runner, "plans", "show", plan["id"], "--db", backend_url, "--json")
    assert by_name.exit_code == 0, by_name.output
    assert json.loads(by_name.stdout) == json.loads(by_id.stdout)
    shown = json.loads(by_name.stdout)
    assert shown["setpoints"]["setpoint_version"] == 1 and shown["strategy"] == "learn"
    assert [o["name"] for o in shown["operations"]] == [o["name"] for o in PLAN["operations"]]
    assert "limits and bounds" in _rcb(runner, "plans", "show", NAME, "--db", backend_url).stdout

    history = _rcb(runner, "history", NAME, "--db", backend_url, "--json")
    assert history.exit_code == 0, history.output
    assert json.loads(history.stdout) == json.loads(
        _rcb(runner, "history", plan["id"], "--db", backend_url, "--json").stdout
    )
    for command in (["history"], ["parts"], ["plans", "show"]):
        unknown = _rcb(runner, *command, "ivester-demo", "--db", backend_url)
        _one_line_error(unknown, "PLAN", "no plan named 'ivester-demo' (rcb plans lists them)")


def test_digit_names_bad_files_and_misplaced_options_one_line(runner, tmp_path):
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    migrated(url)
    digits = tmp_path / "digits.json"
    digits.write_text(json.dumps({**PLAN, "name": "4711"}), encoding="utf-8")
    _one_line_error(_rcb(runner, "plans", "create", digits, "--db", url), "name", "only digits")
    broken = tmp_path / "broken.json"
    broken.write_text("{", encoding="utf-8")
    _one_line_error(_rcb(runner, "plans", "create", broken, "--db", url), "FILE", "not valid JSON")
    missing = tmp_path / "missing.toml"
    _one_line_error(_rcb(runner, "plans", "create", missing, "--db", url), "FILE", "no such file")
    # the group's own options go after the command, not silently ignored
    misplaced = _rcb(runner, "plans", "--db", url, "show", "1")
    _one_line_error(misplaced, "--db", "goes after the command: rcb plans show ... --db")


def test_rest_refuses_a_second_plan_of_a_name(server, runner):
    with server.client("engineer") as c:
        first = c.post("/plans", json={**PLAN, "name": "rest-name"})
        assert first.status_code == 201, first.text
        again = c.post("/plans", json={**PLAN, "name": "rest-name"}, params={"strategy": "bayes"})
        fleet = c.post("/plans", json={**PLAN, "name": "rest-name"}, params={"prior": "fleet"})
        key = {"Idempotency-Key": "rest-name-1"}
        stored = c.post("/plans", json={**PLAN, "name": "rest-name-2"}, headers=key)
        replayed = c.post("/plans", json={**PLAN, "name": "rest-name-2"}, headers=key)
        listed = c.get("/plans").json()["plans"]
    # the name is told before the prior (before: 422, the fleet holds no evidence), and a
    # retry of a stored create is its answer again, not a taken name
    assert (fleet.status_code, fleet.json()["code"]) == (409, "plan_name_taken"), fleet.text
    assert (stored.status_code, replayed.status_code) == (201, 201), replayed.text
    assert replayed.json()["id"] == stored.json()["id"]
    assert again.status_code == 409, again.text
    assert again.headers["content-type"].startswith("application/problem+json")
    problem = again.json()
    assert (problem["code"], problem["field"], problem["value"]) == (
        "plan_name_taken",
        "name",
        "rest-name",
    )
    assert problem["plan_id"] == first.json()["id"]
    assert f"plan {first.json()['id']} has this name" in problem["detail"]
    assert [p["name"] for p in listed].count("rest-name") == 1
    # the command line resolves the REST plan's name on the same database
    shown = _rcb(runner, "plans", "show", "rest-name", "--db", server.url, "--json")
    assert shown.exit_code == 0, shown.output
    assert json.loads(shown.stdout)["id"] == first.json()["id"]


def test_migration_0011_renames_later_duplicates(backend_url):
    upgrade(backend_url, "0010")
    engine = make_engine(backend_url)
    names = ["a", "b", "a", "a#3", "a", "c" * 200, "c" * 200]
    with engine.begin() as connection:
        connection.execute(
            text("INSERT INTO machines (name, created_at) VALUES ('m', :now)"), {"now": utcnow()}
        )
        for name in names:
            connection.execute(
                text(
                    "INSERT INTO plans (name, machine_id, body, strategy, alpha,"
                    " current_setpoint_version, state_token, created_at)"
                    " VALUES (:name, (SELECT id FROM machines), '{}', 'ivester', 0.25, 1, '',"
                    " :now)"
                ),
                {"name": name, "now": utcnow()},
            )
    engine.dispose()
    migrated(backend_url)
    engine = make_engine(backend_url)
    with engine.connect() as connection:
        rows = connection.execute(text("SELECT id, name FROM plans ORDER BY id")).all()
    engine.dispose()
    assert [plan_id for plan_id, _ in rows] == list(range(1, 8))
    assert [name for _, name in rows] == [
        "a",
        "b",
        "a##3",  # the oldest 'a' keeps the name; 'a#3' is another plan's: one more '#'
        "a#3",
        "a#5",
        "c" * 200,
        "c" * 198 + "#7",  # cut to the column's 200 characters
    ]
    _no_difference(backend_url)
