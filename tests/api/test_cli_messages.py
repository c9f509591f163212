"""What ``rcb`` says, in people's words, not Python's (a new user's review).

Before: ``--feed-mm-rev = None: required ...``; ``changes = {}: nothing to change``; ``RCB learn
alpha=0.25 (floors={}, coverage_k=2.0, ...``; ``Value error, 'foo' is not one of 'learn',
'ivester', 'bayes'. (got 'foo')``; ``plan_id = 99: not found`` (a name said ``no plan named
...``); ``rcb replan --help`` showed a docstring's double backquotes. Each message still names
the field and the value, in one line, exit 2. REST keeps its own field and value.
"""

from __future__ import annotations

import json

import pytest
import typer
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session
from typer.testing import CliRunner

from api.cli.helptext import escape_tree
from api.cli.main import app
from api.cli.plans import settings_text
from api.rest.app import create_app
from db.api_keys import create_key
from db.engine import make_engine

from conftest import DEMO_PLAN, invoke
from migrated import migrated


@pytest.fixture(scope="module")
def url(tmp_path_factory) -> str:
    """A SQLite database holding the demonstration plan as plan 1."""
    url = f"sqlite:///{tmp_path_factory.mktemp('messages') / 'rcb.db'}"
    migrated(url)
    done = CliRunner().invoke(app, ["plans", "create", str(DEMO_PLAN), "--db", url])
    assert done.exit_code == 0, done.stderr
    return url


def _error(done) -> str:
    """The one line of an input error (exit 2), without its ``rcb: error: ``."""
    assert done.exit_code == 2, (done.exit_code, done.stderr)
    assert done.stdout == "" and len(done.stderr.splitlines()) == 1, done.stderr
    assert done.stderr.startswith("rcb: error: "), done.stderr
    return done.stderr.strip().removeprefix("rcb: error: ")


def test_a_missing_option_is_named_without_a_value(runner):
    args = ["predict", "--tool", "CNMG432RN", "--depth-mm", "3", "--speed-m-min", "200"]
    said = _error(invoke(runner, *args))
    assert said == "--feed-mm-rev: required for turning tool 'CNMG432RN'"


def test_a_replan_without_a_change_names_the_options_that_make_one(runner, url):
    said = _error(invoke(runner, "replan", "1", "--dry-run", "--db", url))
    assert said == "--limit/--bound/--model/--rcb/--reset-bands: none given: nothing to change"
    assert "{}" not in said and "changes" not in said


def test_plans_show_says_the_rcb_settings_as_rcb_takes_them(runner, url):
    done = invoke(runner, "plans", "show", "1", "--db", url)
    assert done.exit_code == 0, done.stderr
    told = " ".join(line.strip() for line in done.stderr.splitlines())
    expected = "RCB learn alpha=0.25 (coverage_k=2, discrepancy=0, z=4, exponent_sd=0.15, "
    assert expected + "edge_sd=0.1, halt_over=0.25)" in told, told
    for python in ("{", "}", "None", "4.0", "floors="):
        assert python not in told, (python, told)


def test_settings_text_writes_floors_and_no_value_as_rcb_takes_them():
    settings = {"floors": {"force_N": 50.0}, "coverage_k": 2.0, "discrepancy": None, "z": 4.5}
    assert settings_text(settings) == "floors.force_N=50, coverage_k=2, discrepancy=none, z=4.5"
    assert settings_text({"floors": {}, "z": 4.0}) == "z=4"  # no floor: the default, unsaid
    assert (
        settings_text({"coverage_k": 2.3456789, "edge_sd": 0.1})
        == "coverage_k=2.3456789, edge_sd=0.1"
    )


@pytest.mark.parametrize(
    "command",
    [["demo"], ["plans", "create", str(DEMO_PLAN)], ["certify", str(DEMO_PLAN)]],
)
def test_an_unknown_strategy_is_one_line_of_rcb_not_of_typer(runner, command):
    said = _error(invoke(runner, *command, "--strategy", "foo"))
    assert said == "--strategy = 'foo': must be one of learn, ivester, bayes"


def test_the_strategy_option_still_shows_its_choices_and_default(runner):
    done = invoke(runner, "demo", "--help")
    assert "<learn|ivester|bayes>" in done.stdout and "[default: learn]" in done.stdout


def test_an_unknown_plan_id_is_said_as_an_unknown_name_is(runner, url):
    for command in (["plans", "show"], ["history"], ["parts"], ["replan"]):
        extra = ["--reset-bands"] if command == ["replan"] else []
        said = _error(invoke(runner, *command, "99", *extra, "--db", url))
        assert said == "PLAN = 99: no plan with id 99 (rcb plans lists them)", command
    named = _error(invoke(runner, "plans", "show", "nosuch", "--db", url))
    assert named == "PLAN = 'nosuch': no plan named 'nosuch' (rcb plans lists them)"


def test_a_plan_id_out_of_range_or_a_name_too_long_is_refused_before_the_database(runner, url):
    """A year's review: an id of 2^63 or more was a traceback on SQLite (OverflowError), and
    on PostgreSQL from 2^31 (NumericValueOutOfRange); a 100 000-character name was echoed
    whole. The id's range is the database's integer (2^31 - 1), a name's length 200."""
    for command in (["plans", "show"], ["history"], ["parts"]):
        for given in ("99999999999999999999999", "2147483648", "0"):
            done = invoke(runner, *command, given, "--db", url)
            assert done.exit_code == 2, (command, given, done.output)
            assert _error(done) == f"PLAN = '{given}': a plan's id is 1 to 2147483647", command
    long = "x" * 100_000
    done = invoke(runner, "history", long, "--db", url)
    assert done.exit_code == 2 and "a plan's name is at most 200 characters" in done.stderr
    assert len(done.stderr) < 400  # the value is shown clipped, once


def test_rest_keeps_its_own_field_and_value_for_an_unknown_plan(url):
    engine = make_engine(url)
    with Session(engine) as session, session.begin():
        _, key = create_key(session=session, role="viewer")
    engine.dispose()
    with TestClient(create_app(url), headers={"Authorization": f"Bearer {key}"}) as client:
        r = client.get("/api/v1/plans/99")
    assert r.status_code == 404, r.text
    problem = r.json()
    assert (problem["field"], problem["value"]) == ("plan_id", 99)
    assert "rcb plans" not in json.dumps(problem)


def test_replan_help_shows_its_literals_without_backquotes(runner):
    done = invoke(runner, "replan", "--help")
    assert done.exit_code == 0
    text = " ".join(done.stdout.split())
    assert "--rcb NAME=VALUE changes an RCB setting of the plan (--rcb alpha=0.3)." in text
    assert "``" not in done.stdout


def test_no_help_text_shows_a_docstrings_double_backquotes():
    """Every command's help and every option's, as ``--help`` renders them."""
    root = typer.main.get_command(app)
    escape_tree(root)
    shown: list[tuple[str, str]] = []

    def walk(command, path: str) -> None:
        shown.append((path, command.help or ""))
        shown.extend((path, p.help or "") for p in command.params if hasattr(p, "help"))
        for name in getattr(command, "list_commands", lambda _: [])(None):
            walk(command.get_command(None, name), f"{path} {name}")

    walk(root, "rcb")
    assert len(shown) > 100
    assert [path for path, text in shown if "``" in text] == []
