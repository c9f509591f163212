"""``rcb audit --plan``: one plan's history in the audit log, by its id or its name.

On SQLite and PostgreSQL, from real writes: a plan's creation (its id known only once it is
stored), its part reports (answered, replayed and refused), a replan and a fleet exclusion
are the plan's; another plan's are not; the entries carry ``plan_id``. A fleet exclusion or
inclusion of the plan's machine (``--machine``, no ``plan_id``) is listed with each plan of
the machine (it was with none), and another machine's is not.
"""

from __future__ import annotations

import json

import pytest
from sqlalchemy.orm import Session
from test_service import BODY, _reports

from api.cli.main import app
from api.rest.schemas.parts import parse_report
from api.services.idempotency import Idempotency
from api.services.parts import report_part
from api.services.plans import create_plan
from db import audit
from db.engine import make_engine
from db.errors import ConflictError

from migrated import migrated

#: The machine of the example plan.
MACHINE = BODY["machine"]["name"]


def _json(runner, url: str, *args: str) -> dict:
    done = runner.invoke(app, ["audit", "--db", url, "--json", *args])
    assert done.exit_code == 0, done.stderr
    return json.loads(done.stdout)


def _seen(entries: list[dict]) -> list[tuple]:
    return [(e["action"], e["target"], e["result"], e["plan_id"]) for e in entries]


def test_a_plans_history_by_id_and_by_name(runner, backend_url):
    migrated(backend_url)
    engine = make_engine(backend_url)
    first = create_plan(engine=engine, body=BODY).body["id"]
    second = create_plan(engine=engine, body={**BODY, "name": "second-bar"}).body["id"]
    bodies, _ = _reports(2)
    key = Idempotency("part-1", "hash-1")
    report_part(engine=engine, plan_id=first, report=parse_report(bodies[0]), idempotency=key)
    report_part(engine=engine, plan_id=first, report=parse_report(bodies[0]), idempotency=key)
    with pytest.raises(ConflictError):  # the same serial again, without its key: refused
        report_part(engine=engine, plan_id=first, report=parse_report(bodies[0]))
    engine.dispose()
    for step in (
        ("replan", str(first), "--limit", "rough-od.force_N=1900", "--by", "bo"),
        ("fleet", "exclude", "--plan", str(second), "--reason", "wrong stock", "--by", "bo"),
        ("fleet", "exclude", "--machine", MACHINE, "--reason", "spindle", "--by", "bo"),
    ):
        done = runner.invoke(app, [*step, "--db", backend_url])
        assert done.exit_code == 0, done.stderr
    serial = bodies[0]["serial"]
    machine = ("fleet exclude", f"machine {MACHINE}", "200", None)  # its machine's, each plan's
    mine = [
        machine,
        ("replan", f"plan {first}", "201", first),
        ("report part", f"plan {first} part {serial}", "refused", first),
        ("report part", f"plan {first} part {serial}", "replayed 201", first),
        ("report part", f"plan {first} part {serial}", "201", first),
        ("create plan", f"plan {BODY['name']}", "201", first),
    ]
    assert _seen(_json(runner, backend_url, "--plan", str(first))["entries"]) == mine
    assert _seen(_json(runner, backend_url, "--plan", BODY["name"])["entries"]) == mine
    # a creation says the plan's machine, strategy and start (an audit: its detail was null)
    (created,) = _json(runner, backend_url, "--plan", str(first), "--action", "create plan")[
        "entries"
    ]
    assert created["detail"] == {"machine": MACHINE, "strategy": "learn", "prior": "catalogue"}
    theirs = _json(runner, backend_url, "--plan", "second-bar")["entries"]
    assert _seen(theirs) == [
        machine,
        ("fleet exclude", f"plan {second}", "200", second),
        ("create plan", "plan second-bar", "201", second),
    ]
    whole = _json(runner, backend_url)["entries"]
    assert [e["plan_id"] for e in whole if e["target"] == f"machine {MACHINE}"] == [None]
    # an id never stored is refused as an unknown name is (was an empty page, exit 0)
    unknown = runner.invoke(app, ["audit", "--db", backend_url, "--plan", "999"])
    assert unknown.exit_code == 2
    assert unknown.stderr.splitlines() == [
        "rcb: error: --plan = '999': no plan with id 999 (rcb plans lists them)"
    ]


def test_an_id_only_the_audit_log_names_is_kept(runner, backend_url):
    """No command deletes a plan, but the log's plan_id is no foreign key: its entries stay
    readable by the id of a plan the database no longer has."""
    migrated(backend_url)
    engine = make_engine(backend_url)
    with Session(engine) as session, session.begin():
        audit.audit(session=session, actor="rcb", action="create plan", target="plan 77",
                    result="201", plan_id=77)  # fmt: skip
    entries = _json(runner, backend_url, "--plan", "77")["entries"]
    assert _seen(entries) == [("create plan", "plan 77", "201", 77)]


@pytest.mark.parametrize(
    "command",
    [
        ["audit"],
        ["fleet", "exclude", "--reason", "wrong stock"],  # the same option, the same words
        ["fleet", "include"],
    ],
)
def test_an_unknown_plan_name_is_one_line_naming_the_option(runner, tmp_path, command):
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    migrated(url)
    done = runner.invoke(app, [*command, "--db", url, "--plan", "no-such-plan"])
    assert done.exit_code == 2
    assert done.stderr.startswith("rcb: error: --plan = 'no-such-plan': no plan named")
    assert len(done.stderr.strip().splitlines()) == 1


def test_a_plans_history_lists_its_machines_fleet_entries_and_no_other_machines(
    runner, backend_url
):
    migrated(backend_url)
    engine = make_engine(backend_url)
    mine = create_plan(engine=engine, body=BODY).body["id"]
    other = {**BODY, "name": "other-bar", "machine": {**BODY["machine"], "name": "lathe-z"}}
    create_plan(engine=engine, body=other)
    engine.dispose()
    for machine, command, by in (
        (MACHINE, "exclude", "bo"),
        ("lathe-z", "exclude", "bo"),
        (MACHINE, "include", "cy"),
        ("lathe-z", "include", "cy"),
    ):
        reason = ("--reason", "spindle") if command == "exclude" else ()
        step = ("fleet", command, "--machine", machine, *reason, "--by", by)
        done = runner.invoke(app, [*step, "--db", backend_url])
        assert done.exit_code == 0, done.stderr
    target = f"machine {MACHINE}"
    listed = _json(runner, backend_url, "--plan", str(mine))["entries"]
    assert _seen(listed) == [
        ("fleet include", target, "200", None),
        ("fleet exclude", target, "200", None),
        ("create plan", f"plan {BODY['name']}", "201", mine),
    ]
    # with the other filters, and a page at a time as the rest (each page chains to the next)
    only = _json(runner, backend_url, "--plan", str(mine), "--action", "fleet include")
    assert _seen(only["entries"]) == [("fleet include", target, "200", None)]
    by_bo = _json(runner, backend_url, "--plan", str(mine), "--actor", "cli:bo")["entries"]
    assert _seen(by_bo) == [("fleet exclude", target, "200", None)]
    assert _json(runner, backend_url, "--plan", str(mine), "--action", "replan")["entries"] == []
    paged, cursor = [], []
    while True:
        page = _json(runner, backend_url, "--plan", str(mine), "--limit", "1", *cursor)
        paged += page["entries"]
        if page["next_cursor"] is None:
            break
        cursor = ["--cursor", page["next_cursor"]]
    assert paged == listed
