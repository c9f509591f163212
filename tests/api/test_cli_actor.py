"""Issue 18 item 10: who made a command-line write is recorded, as ``cli:NAME``.

``rcb replan``, ``keys create|revoke`` and ``db prune`` take ``--by NAME`` (default: the OS
user); the audit log and a replan's setpoint version (``rcb history``, GET history) say who,
as a REST replan's say ``key:ID``. SQLite and PostgreSQL; the REST side on a real server.
"""

from __future__ import annotations

import getpass
import json
import os

import pytest
from sqlalchemy import select
from sqlalchemy.orm import Session
from test_service import BODY

from api.cli.main import app
from api.cli.who import MAX_NAME, os_user
from api.services.plans import create_plan
from db import tables as t
from db.engine import make_engine

from migrated import migrated

LIMIT = ["--limit", "rough-od.force_N=2200"]


def _audit(url: str) -> list[tuple[str, str, str]]:
    engine = make_engine(url)
    with Session(engine) as session:
        rows = session.execute(
            select(t.AuditEntry.actor, t.AuditEntry.action, t.AuditEntry.target).order_by(
                t.AuditEntry.id
            )
        ).all()
    engine.dispose()
    return [tuple(row) for row in rows]


@pytest.fixture
def plan_db(backend_url) -> tuple[str, int]:
    """A migrated database holding the test plan: its URL and the plan's id."""
    migrated(backend_url)
    engine = make_engine(backend_url)
    plan_id = create_plan(engine=engine, body=BODY).body["id"]
    engine.dispose()
    return backend_url, plan_id


def test_rcb_replan_by_is_in_the_audit_log_and_the_history(runner, plan_db):
    url, plan_id = plan_db
    done = runner.invoke(app, ["replan", str(plan_id), "--db", url, *LIMIT, "--by", "alice"])
    assert done.exit_code == 0, done.output
    assert _audit(url)[-1] == ("cli:alice", "replan", f"plan {plan_id}")
    shown = runner.invoke(app, ["history", str(plan_id), "--db", url, "--json"])
    versions = json.loads(shown.stdout)["versions"]
    assert [(v["version"], v["cause"], v["actor"]) for v in versions] == [
        (1, "initial", None),
        (2, "replan", "cli:alice"),
    ]
    table = runner.invoke(app, ["history", str(plan_id), "--db", url])
    assert "cli:alice" in table.stdout  # under "replan" in the cause column (80 columns)


def test_the_default_is_the_os_user(runner, plan_db, monkeypatch):
    url, plan_id = plan_db
    monkeypatch.setenv("LOGNAME", "operator7")  # getpass.getuser reads LOGNAME first
    done = runner.invoke(app, ["replan", str(plan_id), "--db", url, *LIMIT])
    assert done.exit_code == 0, done.output
    assert _audit(url)[-1][0] == "cli:operator7"


def test_a_user_the_os_cannot_name_is_recorded_by_uid(monkeypatch):
    def nobody() -> str:
        raise OSError("No username set in the environment")

    monkeypatch.setattr(getpass, "getuser", nobody)
    assert os_user() == f"uid {os.getuid()}"


def test_keys_and_prune_record_who(runner, plan_db):
    url, _ = plan_db
    created = runner.invoke(
        app, ["keys", "create", "--role", "mes", "--db", url, "--json", "--by", "bob"]
    )
    assert created.exit_code == 0, created.output
    key_id = json.loads(created.stdout)["id"]
    revoked = runner.invoke(app, ["keys", "revoke", str(key_id), "--db", url, "--by", "carol"])
    assert revoked.exit_code == 0, revoked.output
    pruned = runner.invoke(app, ["db", "prune", "--db", url, "--by", "dave"])
    assert pruned.exit_code == 0, pruned.output
    assert [(actor, action) for actor, action, _ in _audit(url)[-3:]] == [
        ("cli:bob", "create key"),
        ("cli:carol", "revoke key"),
        ("cli:dave", "prune"),
    ]


def test_revoking_twice_says_so_and_audits_once(runner, plan_db):
    """A second revoke changes nothing and writes nothing; an id past the column is not a
    traceback (an OverflowError before) but no such key."""
    url, _ = plan_db
    created = runner.invoke(app, ["keys", "create", "--role", "mes", "--db", url, "--json"])
    key_id = json.loads(created.stdout)["id"]
    first = runner.invoke(app, ["keys", "revoke", str(key_id), "--db", url, "--by", "carol"])
    again = runner.invoke(app, ["keys", "revoke", str(key_id), "--db", url, "--by", "dave"])
    assert first.exit_code == again.exit_code == 0, again.output
    assert f"key {key_id} (mes) was already revoked, at " in again.output
    assert [a for a in _audit(url) if a[1] == "revoke key"] == [
        ("cli:carol", "revoke key", f"key {key_id}")
    ]
    huge = runner.invoke(app, ["keys", "revoke", "9" * 20, "--db", url])
    assert huge.exit_code == 2
    assert huge.output.strip() == f"rcb: error: ID = {'9' * 20}: no such API key"


def test_the_next_page_of_keys_names_the_database_read(runner, plan_db):
    url, _ = plan_db
    for _ in range(2):
        runner.invoke(app, ["keys", "create", "--role", "viewer", "--db", url])
    listed = runner.invoke(app, ["keys", "list", "--limit", "1", "--db", url])
    assert listed.exit_code == 0, listed.output
    hint = listed.output[listed.output.index("rcb: more keys:") :]
    assert f"--db {url}" in hint or "--db URL" in hint  # a URL with a password is not printed


@pytest.mark.parametrize(
    ("by", "reason"),
    [
        ("", "a name is needed"),
        ("   ", "a name is needed"),
        ("eve\x1b[2J", "no control or invisible characters"),
        ("mallory\u202e", "no control or invisible characters"),
        ("x" * (MAX_NAME + 1), f"at most {MAX_NAME} characters"),
    ],
    ids=["empty", "blank", "escape", "bidi-override", "too-long"],
)
@pytest.mark.parametrize(
    "command",
    [["replan", "{plan}", *LIMIT], ["keys", "create", "--role", "mes"], ["db", "prune"]],
    ids=["replan", "keys-create", "prune"],
)
def test_a_bad_name_is_one_error_line_and_nothing_is_written(runner, plan_db, by, reason, command):
    url, plan_id = plan_db
    before = _audit(url)
    args = [arg.replace("{plan}", str(plan_id)) for arg in command]
    result = runner.invoke(app, [*args, "--db", url, "--by", by])
    assert result.exit_code == 2, result.output
    assert result.stderr.startswith("rcb: error: --by = ") and reason in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert _audit(url) == before


def test_get_history_says_who_replanned_over_rest_and_at_the_command_line(runner, server):
    with server.client("engineer") as c:
        plan_id = c.post("/plans", json=BODY).json()["id"]
        r = c.post(f"/plans/{plan_id}/replan", json={"limits": {"rough-od.force_N": 2300}})
        assert r.status_code == 201, r.text
    done = runner.invoke(
        app, ["replan", str(plan_id), "--db", server.url, *LIMIT, "--by", "Jane Doe"]
    )
    assert done.exit_code == 0, done.output
    with server.client("viewer") as c:
        versions = c.get(f"/plans/{plan_id}/history").json()["versions"]
    engineer_key = [a for a, action, _ in _audit(server.url) if action == "replan"][0]
    assert engineer_key.startswith("key:")
    assert [(v["cause"], v["actor"]) for v in versions] == [
        ("initial", None),
        ("replan", engineer_key),
        ("replan", "cli:Jane Doe"),
    ]


@pytest.mark.parametrize("command", [["list"], ["revoke", "1"]])
def test_keys_list_and_revoke_do_not_create_a_database(tmp_path, runner, command):
    """A lockout review: they created (and migrated) an empty ./rcb.db where none was."""
    url = f"sqlite:///{tmp_path / 'none.db'}"
    result = runner.invoke(app, ["keys", *command, "--db", url])
    assert result.exit_code == 2 and "no such database file" in result.output
    assert not (tmp_path / "none.db").exists()
